"""A role's parameters from the scenario's ``args`` (``SWARMSITL_PARAMS``), read strictly.

Each role program keeps its parameters in a frozen dataclass that checks its own values; this
builds one from the JSON object, so that a misspelt key in a scenario file is an error that
names it rather than a default silently used.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import Any, TypeVar

T = TypeVar("T")


def params_from_mapping(cls: type[T], params: Mapping[str, object] | None) -> T:
    """``cls(**params)`` for a dataclass ``cls``; an unknown key is a ValueError naming it."""
    values = dict(params or {})
    known = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(values) - known)
    if unknown:
        raise ValueError(f"PARAMS: unknown key(s) {unknown}; known: {sorted(known)}")
    built: Any = cls(**values)
    return built
