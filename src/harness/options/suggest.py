"""Suggestions ("did you mean ...?") for a name that is not one of the known ones.

Every place the harness rejects a name a person typed (a scenario key, a companion argument, an
autopilot parameter, a sweep path) ends its message with :func:`did_you_mean`: the close matches
among the known names, or, with none close, the names themselves, so that the fix is in the
message. ``autopilot_emu`` and ``companion`` cannot import the harness; they use ``difflib``
with the same settings (:data:`MAX_MATCHES`, :data:`CUTOFF`).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

MAX_MATCHES = 3
"""Close matches named at most."""
CUTOFF = 0.5
"""Least ``difflib`` similarity ratio (0..1) of a close match."""


def close_matches(word: str, choices: Iterable[str]) -> list[str]:
    """The known names closest to ``word``, best first (at most :data:`MAX_MATCHES`)."""
    return difflib.get_close_matches(word, list(choices), n=MAX_MATCHES, cutoff=CUTOFF)


def did_you_mean(
    word: str, choices: Iterable[str], listing: str = "known", otherwise: str | None = None
) -> str:
    """``"; did you mean a or b?"``, else ``"; LISTING: every, known, name"`` ("" for none).

    Args:
        word: the name that is not known.
        choices: the names that are (listed in the given order when none is close).
        listing: what introduces the list of every name when none is close.
        otherwise: said instead of that list when none is close (for long lists).
    """
    names = list(choices)
    near = close_matches(word, names)
    if near:
        return f"; did you mean {' or '.join(near)}?"
    if otherwise is not None:
        return otherwise
    return f"; {listing}: {', '.join(names)}" if names else ""
