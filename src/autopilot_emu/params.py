"""PX4 parameters of one emulated vehicle.

The parameter table lives in ``px4_params.yaml`` next to this module: name, MAVLink type (INT32 or
REAL32, fixed forever), default, inclusive range, unit and description of each parameter, in
param_index order. A :class:`ParamStore` holds the current values of one vehicle and validates
every write the way the MAVLink parameter protocol needs (unknown name, wrong type, out of range).

REAL32 values are stored rounded to float32, as PX4 stores them, so the value read back over
MAVLink is exactly the value stored. On the wire PX4 uses *bytewise* encoding:
:func:`encode_param_value` / :func:`decode_param_value` copy the four bytes of an INT32 into the
float ``param_value`` field instead of converting the number.
"""

from __future__ import annotations

import difflib
import functools
import importlib.resources
import math
import numbers
import operator
import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml
from pymavlink.dialects.v20 import common as mavlink2

MAV_PARAM_TYPE_INT32: int = mavlink2.MAV_PARAM_TYPE_INT32
"""MAV_PARAM_TYPE of integer parameters (6)."""
MAV_PARAM_TYPE_REAL32: int = mavlink2.MAV_PARAM_TYPE_REAL32
"""MAV_PARAM_TYPE of float parameters (9)."""

PARAM_ERROR_DOES_NOT_EXIST: int = mavlink2.MAV_PARAM_ERROR_DOES_NOT_EXIST
PARAM_ERROR_VALUE_OUT_OF_RANGE: int = mavlink2.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE
PARAM_ERROR_TYPE_MISMATCH: int = getattr(mavlink2, "MAV_PARAM_ERROR_TYPE_MISMATCH", 7)
"""MAV_PARAM_ERROR_TYPE_MISMATCH is 7 in current common.xml; older pymavlink releases lack it."""

PARAM_ID_MAX_LEN = 16
"""MAVLink param_id length; names of exactly 16 characters carry no terminator."""

_TYPE_BY_NAME = {"INT32": MAV_PARAM_TYPE_INT32, "REAL32": MAV_PARAM_TYPE_REAL32}
_SPEC_RESOURCE = "px4_params.yaml"
_INT32 = struct.Struct("<i")
_FLOAT32 = struct.Struct("<f")
# INT32 values whose bit pattern is a signalling NaN (int32 2139095041..2143289343 and
# -8388607..-4194305) do not survive a trip through a Python float before CPython 3.14, so the
# table keeps INT32 ranges clear of them.
_INT32_WIRE_SAFE_MIN = -(1 << 22)
_INT32_WIRE_SAFE_MAX = 0x7F800000

ParamValue = int | float


def unknown_param_message(name: str, names: Iterable[str]) -> str:
    """``unknown parameter 'X'; did you mean Y or Z?`` with the close names among ``names``.

    ``difflib`` with ``harness.options.suggest``'s settings (the autopilot cannot import the
    harness);
    with no close name it says where the table is.
    """
    near = difflib.get_close_matches(name, list(names), n=3, cutoff=0.5)
    if near:
        return f"unknown parameter {name!r}; did you mean {' or '.join(near)}?"
    return f"unknown parameter {name!r} (this autopilot's are in autopilot_emu/{_SPEC_RESOURCE})"


class ParamError(Exception):
    """A parameter read or write failed; ``code`` is the MAV_PARAM_ERROR value to report."""

    def __init__(self, code: int, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


@dataclass(frozen=True)
class ParamSpec:
    """Definition of one parameter, as read from ``px4_params.yaml``."""

    name: str
    """PX4 name, at most 16 ASCII characters."""
    mav_type: int
    """MAV_PARAM_TYPE: 6 INT32 or 9 REAL32."""
    default: ParamValue
    """Default value (REAL32 rounded to float32)."""
    min_value: ParamValue
    """Smallest accepted value, inclusive."""
    max_value: ParamValue
    """Largest accepted value, inclusive."""
    unit: str
    """Unit of the value ("" when dimensionless)."""
    description: str
    """One-line description."""


def encode_param_value(value: ParamValue, mav_type: int) -> float:
    """Return the PARAM_VALUE/PARAM_SET ``param_value`` float for ``value`` (PX4 bytewise)."""
    if mav_type == MAV_PARAM_TYPE_INT32:
        try:
            packed = _INT32.pack(operator.index(value))
        except struct.error as exc:
            raise ValueError(f"{value!r} does not fit in an INT32") from exc
        return _FLOAT32.unpack(packed)[0]
    if mav_type == MAV_PARAM_TYPE_REAL32:
        return float(value)
    raise ValueError(f"unsupported MAV_PARAM_TYPE {mav_type}")


def decode_param_value(raw_float: float, mav_type: int) -> ParamValue:
    """Return the value carried by a ``param_value`` float of type ``mav_type`` (PX4 bytewise)."""
    if mav_type == MAV_PARAM_TYPE_INT32:
        return _INT32.unpack(_FLOAT32.pack(raw_float))[0]
    if mav_type == MAV_PARAM_TYPE_REAL32:
        return float(raw_float)
    raise ValueError(f"unsupported MAV_PARAM_TYPE {mav_type}")


def _to_float32(value: float) -> float:
    """Round ``value`` to the nearest float32; OverflowError if it is beyond float32 range."""
    return _FLOAT32.unpack(_FLOAT32.pack(value))[0]


def _coerce(spec_type: int, value: Any, name: str) -> ParamValue:
    """Convert ``value`` to the storage type of a parameter or raise a ParamError."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParamError(
            PARAM_ERROR_TYPE_MISMATCH, f"{name}: {value!r} is not a number of the right type"
        )
    if spec_type == MAV_PARAM_TYPE_INT32:
        if not isinstance(value, numbers.Integral):
            raise ParamError(PARAM_ERROR_TYPE_MISMATCH, f"{name} is INT32, got {value!r}")
        return int(value)
    as_float = float(value)
    if not math.isfinite(as_float):
        raise ParamError(PARAM_ERROR_VALUE_OUT_OF_RANGE, f"{name}: {value!r} is not finite")
    try:
        return _to_float32(as_float)
    except OverflowError as exc:
        raise ParamError(
            PARAM_ERROR_VALUE_OUT_OF_RANGE, f"{name}: {value!r} exceeds the float32 range"
        ) from exc


def parse_param_specs(document: Mapping[str, Any]) -> tuple[ParamSpec, ...]:
    """Validate a parsed ``px4_params.yaml`` document and return its specs in index order."""
    entries = document.get("params") if isinstance(document, Mapping) else None
    if not isinstance(entries, list) or not entries:
        raise ValueError("parameter table needs a non-empty 'params' list")
    specs: list[ParamSpec] = []
    seen: set[str] = set()
    for position, entry in enumerate(entries):
        specs.append(_parse_entry(position, entry, seen))
    if len(specs) > 0xFFFF:
        raise ValueError("MAVLink param_index is 16 bits: at most 65535 parameters")
    return tuple(specs)


def _parse_entry(position: int, entry: Any, seen: set[str]) -> ParamSpec:
    """Validate one YAML entry."""
    required = ("name", "type", "default", "min", "max", "unit", "description")
    if not isinstance(entry, Mapping) or any(key not in entry for key in required):
        raise ValueError(f"params[{position}] needs the keys {', '.join(required)}")
    name = entry["name"]
    if not isinstance(name, str) or not name.isascii() or not 0 < len(name) <= PARAM_ID_MAX_LEN:
        raise ValueError(f"params[{position}]: name must be 1..16 ASCII characters: {name!r}")
    if name in seen:
        raise ValueError(f"duplicate parameter {name}")
    seen.add(name)
    if entry["type"] not in _TYPE_BY_NAME:
        raise ValueError(f"{name}: type must be INT32 or REAL32, got {entry['type']!r}")
    mav_type = _TYPE_BY_NAME[entry["type"]]
    try:
        default, low, high = (
            _coerce(mav_type, entry[key], name) for key in ("default", "min", "max")
        )
    except ParamError as exc:
        raise ValueError(f"{name}: default/min/max: {exc.message}") from exc
    if not low <= default <= high:
        raise ValueError(f"{name}: default {default} outside [{low}, {high}]")
    if mav_type == MAV_PARAM_TYPE_INT32 and (
        low < _INT32_WIRE_SAFE_MIN or high > _INT32_WIRE_SAFE_MAX
    ):
        raise ValueError(
            f"{name}: INT32 range must stay within "
            f"[{_INT32_WIRE_SAFE_MIN}, {_INT32_WIRE_SAFE_MAX}] to survive bytewise encoding"
        )
    return ParamSpec(
        name=name,
        mav_type=mav_type,
        default=default,
        min_value=low,
        max_value=high,
        unit=str(entry["unit"]),
        description=str(entry["description"]),
    )


@functools.cache
def load_param_specs() -> tuple[ParamSpec, ...]:
    """Return the packaged PX4 parameter table (parsed once per process)."""
    text = importlib.resources.files(__package__).joinpath(_SPEC_RESOURCE).read_text("utf-8")
    return parse_param_specs(yaml.safe_load(text))


@functools.cache
def _index_by_name(specs: tuple[ParamSpec, ...]) -> Mapping[str, int]:
    """Name -> index for a spec table, shared by every store built from it."""
    return {spec.name: index for index, spec in enumerate(specs)}


class ParamStore:
    """Current PX4 parameter values of one vehicle.

    Args:
        overrides: name -> value applied over the defaults, validated like :meth:`set`.

    Raises:
        ParamError: an override names an unknown parameter or has a bad type or value.
    """

    def __init__(self, overrides: Mapping[str, ParamValue] | None = None) -> None:
        self._specs = load_param_specs()
        self._index = _index_by_name(self._specs)
        self._names = tuple(spec.name for spec in self._specs)
        self._values: dict[str, ParamValue] = {spec.name: spec.default for spec in self._specs}
        self._version = 0
        self._floats: dict[str, float] | None = None
        self._client_set: set[str] = set()
        for name, value in (overrides or {}).items():
            self.set(name, value)
        self._version = 0

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in param_index order."""
        return self._names

    @property
    def count(self) -> int:
        """Number of parameters (MAVLink param_count)."""
        return len(self._names)

    @property
    def version(self) -> int:
        """Counter incremented whenever a value changes; 0 right after construction."""
        return self._version

    def spec(self, name: str) -> ParamSpec:
        """Definition of ``name``."""
        return self._specs[self.index_of(name)]

    def index_of(self, name: str) -> int:
        """MAVLink param_index of ``name``."""
        try:
            return self._index[name]
        except KeyError:
            raise ParamError(
                PARAM_ERROR_DOES_NOT_EXIST, unknown_param_message(name, self._names)
            ) from None

    def name_at(self, index: int) -> str:
        """Name of the parameter at MAVLink param_index ``index``."""
        if not 0 <= index < len(self._names):
            raise ParamError(PARAM_ERROR_DOES_NOT_EXIST, f"no parameter at index {index}")
        return self._names[index]

    def type_of(self, name: str) -> int:
        """MAV_PARAM_TYPE of ``name`` (6 INT32, 9 REAL32)."""
        return self._specs[self.index_of(name)].mav_type

    def get(self, name: str) -> ParamValue:
        """Current value of ``name``."""
        try:
            return self._values[name]
        except KeyError:
            raise ParamError(
                PARAM_ERROR_DOES_NOT_EXIST, unknown_param_message(name, self._names)
            ) from None

    def floats(self) -> Mapping[str, float]:
        """Every value as a float, name -> value (read-only by convention).

        Built once and kept until a value changes: the 50 Hz loops read a dozen parameters per
        tick, and one dictionary look-up is cheaper than ``float(get(name))``.
        """
        cache = self._floats
        if cache is None:
            cache = self._floats = {name: float(value) for name, value in self._values.items()}
        return cache

    def set(self, name: str, value: ParamValue) -> ParamValue:
        """Validate and store ``value``; return the stored value (REAL32 rounded to float32).

        Raises:
            ParamError: DOES_NOT_EXIST, TYPE_MISMATCH (a non-integer for an INT32, a non-number),
                or VALUE_OUT_OF_RANGE (outside [min, max], NaN or infinite).
        """
        spec = self._specs[self.index_of(name)]
        stored = _coerce(spec.mav_type, value, name)
        if not spec.min_value <= stored <= spec.max_value:
            raise ParamError(
                PARAM_ERROR_VALUE_OUT_OF_RANGE,
                f"{name}: {value!r} outside [{spec.min_value}, {spec.max_value}] {spec.unit}",
            )
        if self._values[name] != stored:
            self._values[name] = stored
            self._version += 1
            self._floats = None
        return stored

    def set_from_client(self, name: str, value: ParamValue) -> ParamValue:
        """:meth:`set` on behalf of a MAVLink client (PARAM_SET); the name joins :attr:`client_set`.

        Raises:
            ParamError: as :meth:`set` (nothing is noted then).
        """
        stored = self.set(name, value)
        self._client_set.add(name)
        return stored

    @property
    def client_set(self) -> tuple[str, ...]:
        """Names MAVLink clients set (:meth:`set_from_client`), in param_index order.

        What a run saves on exit, so that the next one can start from them.
        """
        return tuple(name for name in self._names if name in self._client_set)


def param_column(stores: list[ParamStore], name: str, scale: float = 1.0) -> np.ndarray:
    """Parameter ``name`` of every vehicle's store as a float array (N,), times ``scale``."""
    return np.array([float(store.get(name)) * scale for store in stores])
