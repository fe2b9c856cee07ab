"""A role's parameters from the scenario's ``args`` (``SWARMSITL_PARAMS``), read strictly.

Each role program keeps its parameters in a frozen dataclass that checks its own values; this
builds one from the JSON object, so that a misspelt key in a scenario file is an error that
names it (and the close known keys) rather than a default silently used.

A program module declares that dataclass as its module-level ``PARAMS`` (``PARAMS =
CoverageParams``): ``swarmsitl run`` then checks a role's ``args`` with
:func:`params_from_mapping` when it loads the scenario, before anything starts
(docs/companions.md, "Declaring a program's parameters").
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from dataclasses import fields
from typing import Any, TypeVar

T = TypeVar("T")

PARAMS_ATTRIBUTE = "PARAMS"
"""Name of the module-level variable holding a program's parameter dataclass."""
RUN_CHECK = "check_run"
"""Optional method of a PARAMS dataclass, ``check_run(self, vehicles: int, world) -> None``:
raise ValueError (naming the value) if the role cannot run with ``vehicles`` vehicles in
``world`` (a built ``worlds.World`` or None). ``swarmsitl run`` calls it when it loads the
scenario, so that a fleet too large for the plan fails before anything starts."""


class UnknownParamsError(ValueError):
    """``args`` name keys the parameter dataclass does not have."""

    def __init__(self, unknown: list[str], known: list[str]) -> None:
        self.unknown = unknown
        """The keys not known, sorted."""
        self.known = known
        """Every key the dataclass takes, sorted."""
        # difflib as harness.options.suggest does (companion code cannot import the harness).
        near = difflib.get_close_matches(unknown[0], known, n=3, cutoff=0.5)
        hint = f"; did you mean {' or '.join(near)}?" if near else ""
        super().__init__(f"PARAMS: unknown key(s) {unknown}{hint}; known: {known}")


def params_from_mapping(cls: type[T], params: Mapping[str, object] | None) -> T:
    """``cls(**params)`` for a dataclass ``cls``.

    Raises:
        UnknownParamsError: a key is not a field of ``cls`` (a ValueError naming it).
        ValueError, TypeError: what ``cls`` raises for a bad value or a missing field.
    """
    values = dict(params or {})
    known = sorted(f.name for f in fields(cls))  # type: ignore[arg-type]
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise UnknownParamsError(unknown, known)
    built: Any = cls(**values)
    return built
