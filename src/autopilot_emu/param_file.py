"""QGroundControl ``.params`` files: read them into checked rows, write them from a store.

The format is QGroundControl's "Save to file" (``ParameterManager::writeParametersToStream``):
lines starting with ``#`` are comments, every other line is one parameter,

    Vehicle-Id <TAB> Component-Id <TAB> Name <TAB> Value <TAB> Type

where Vehicle-Id is the MAVLink system id the row belongs to, Component-Id its component (1: the
autopilot), and Type the MAV_PARAM_TYPE (6 INT32, 9 REAL32). QGroundControl writes tabs; runs of
spaces (as some tools write) are accepted too. Values are decimal text: INT32 as an integer,
REAL32 as the shortest decimal that reads back as the same float32 (``0.3``, ``1``), as current
QGroundControl writes them; older QGroundControl's 18-decimal form (``0.300000011920928955``)
reads back as the same float32 as well.

Rows of the autopilot (component 1) are checked against this autopilot's parameter table through
:class:`~autopilot_emu.params.ParamStore` (unknown name, a Type other than the parameter's, a value
that is not a number of that type or is outside its range); rows of other components (a camera,
a gimbal) are only checked for shape, since their parameters are not this autopilot's. Every error
is a :class:`ParamFileError` naming the file and the line.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

from autopilot_emu.params import (
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
    PARAM_ID_MAX_LEN,
    ParamError,
    ParamStore,
    ParamValue,
    unknown_param_message,
)

AUTOPILOT_COMPONENT_ID = 1
"""MAV_COMP_ID_AUTOPILOT1: the only component whose rows load into the autopilot."""
COLUMNS_COMMENT = "# Vehicle-Id Component-Id Name Value Type"
"""The comment QGroundControl writes above the rows."""
_TYPE_NAMES = {
    1: "UINT8",
    2: "INT8",
    3: "UINT16",
    4: "INT16",
    5: "UINT32",
    6: "INT32",
    7: "UINT64",
    8: "INT64",
    9: "REAL32",
    10: "REAL64",
}
"""MAV_PARAM_TYPE values and names (common.xml)."""
_INT32_MIN, _INT32_MAX = -(1 << 31), (1 << 31) - 1


class ParamFileError(ValueError):
    """A ``.params`` file that cannot be loaded; the message is ``FILE:LINE: what is wrong``."""

    def __init__(self, source: str, line: int | None, message: str) -> None:
        where = f"{source}:{line}" if line is not None else source
        super().__init__(f"{where}: {message}")
        self.source = source
        """The file (as given) or another name of the text."""
        self.line = line
        """1-based line number; None for the file as a whole (not found, unreadable)."""
        self.message = message
        """What is wrong, without the place."""


@dataclass(frozen=True)
class ParamRow:
    """One parameter line of a ``.params`` file."""

    vehicle_id: int
    """MAVLink system id the row belongs to, 1..255."""
    component_id: int
    """MAVLink component id, 0..255 (1: the autopilot)."""
    name: str
    """Parameter name, at most 16 ASCII characters."""
    value: ParamValue
    """INT32: an int; REAL32: a float rounded to float32; other components: the number read."""
    mav_type: int
    """MAV_PARAM_TYPE (6 INT32, 9 REAL32, ...)."""
    line: int = 0
    """1-based line number in the file it came from (0: not read from a file)."""


def type_name(mav_type: int) -> str:
    """``INT32`` for 6, ``REAL32`` for 9, ... (the number itself when unknown)."""
    return _TYPE_NAMES.get(mav_type, str(mav_type))


def format_value(value: ParamValue, mav_type: int) -> str:
    """The Value column: an integer, or the shortest decimal that reads back as the float32."""
    if mav_type == MAV_PARAM_TYPE_REAL32:
        return np.format_float_positional(np.float32(value), unique=True, trim="-")
    return str(int(value))


def _integer(text: str) -> int | None:
    """``text`` as an integer (``5``, ``-3``, ``5.0``), None when it is not one."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        number = float(text)
    except ValueError:
        return None
    return int(number) if math.isfinite(number) and number.is_integer() else None


def _ranged_int(text: str, low: int, high: int, what: str, fail: _Fail) -> int:
    number = _integer(text)
    if number is None or not low <= number <= high:
        fail(f"{what} must be an integer {low}..{high}, got {text!r}")
    return number


class _Fail:
    """Raises the ParamFileError of one line."""

    def __init__(self, source: str, line: int) -> None:
        self.source = source
        self.line = line

    def __call__(self, message: str) -> NoReturn:
        raise ParamFileError(self.source, self.line, message)


def _autopilot_value(
    fields: list[str], mav_type: int, store: ParamStore, fail: _Fail
) -> ParamValue:
    """Check an autopilot row's name, type and value against ``store``; the value to set."""
    name, text = fields[2], fields[3]
    try:
        spec = store.spec(name)
    except ParamError:
        fail(unknown_param_message(name, store.names))
    if mav_type != spec.mav_type:
        fail(
            f"{name} is {type_name(spec.mav_type)} (type {spec.mav_type}), the line gives type "
            f"{mav_type} ({type_name(mav_type)})"
        )
    if spec.mav_type == MAV_PARAM_TYPE_INT32:
        number = _integer(text)
        if number is None:
            fail(f"{name} is INT32: {text!r} is not an integer")
        if not _INT32_MIN <= number <= _INT32_MAX:
            fail(f"{name}: {text} is outside the INT32 range [{_INT32_MIN}, {_INT32_MAX}]")
        value: ParamValue = number
    else:
        try:
            value = float(text)
        except ValueError:
            fail(f"{name} is REAL32: {text!r} is not a number")
    try:
        return store.set(name, value)
    except ParamError as exc:
        fail(exc.message)


def parse_param_file(text: str, source: str = "<params>") -> tuple[ParamRow, ...]:
    """The rows of a ``.params`` text, checked; ParamFileError naming ``source`` and the line."""
    store = ParamStore()
    rows = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        fail = _Fail(source, number)
        fields = line.split()
        if len(fields) != 5:
            fail(
                f"expected 5 tab-separated fields (Vehicle-Id Component-Id Name Value Type), "
                f"got {len(fields)}: {line[:60]!r}"
            )
        vehicle = _ranged_int(fields[0], 1, 255, "Vehicle-Id", fail)
        component = _ranged_int(fields[1], 0, 255, "Component-Id", fail)
        mav_type = _ranged_int(fields[4], 1, 10, "Type (MAV_PARAM_TYPE)", fail)
        name = fields[2]
        if not name.isascii() or len(name) > PARAM_ID_MAX_LEN:
            fail(f"parameter name {name[:40]!r} is not 1..16 ASCII characters")
        if component == AUTOPILOT_COMPONENT_ID:
            value = _autopilot_value(fields, mav_type, store, fail)
        else:
            try:
                value = float(fields[3])
            except ValueError:
                fail(f"{name}: {fields[3]!r} is not a number")
        rows.append(ParamRow(vehicle, component, name, value, mav_type, number))
    return tuple(rows)


def read_param_file(path: Path) -> tuple[ParamRow, ...]:
    """The checked rows of the file at ``path``; ParamFileError naming it (and the line)."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ParamFileError(str(path), None, exc.strerror or str(exc)) from exc
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise ParamFileError(str(path), line, "not text (UTF-8)") from exc
    return parse_param_file(text, str(path))


def store_rows(
    vehicle_id: int, store: ParamStore, names: Iterable[str] | None = None
) -> list[ParamRow]:
    """Rows of the autopilot's parameters ``names`` (default: all) with their current values."""
    return [
        ParamRow(vehicle_id, AUTOPILOT_COMPONENT_ID, name, store.get(name), store.type_of(name))
        for name in (store.names if names is None else names)
    ]


def format_param_file(rows: Sequence[ParamRow], comments: Sequence[str] = ()) -> str:
    """A ``.params`` text QGroundControl loads: its header, then rows by vehicle, component, name.

    ``comments`` become ``#`` lines after the first; QGroundControl loads a file only onto the
    vehicle whose id its rows name (one-vehicle files for it, any for ``swarmsitl up --params``).
    """
    vehicles = sorted({row.vehicle_id for row in rows})
    if len(vehicles) == 1:
        title = f"# Onboard parameters for Vehicle {vehicles[0]}"
    else:
        title = f"# Onboard parameters for Vehicles {', '.join(map(str, vehicles)) or 'none'}"
    lines = [title, "#", "# Stack: PX4 Pro", "# Vehicle: Multi-Rotor"]
    lines += [f"# {comment}" for comment in comments]
    lines += ["#", COLUMNS_COMMENT]
    for row in sorted(rows, key=lambda r: (r.vehicle_id, r.component_id, r.name)):
        value = format_value(row.value, row.mav_type)
        lines.append(f"{row.vehicle_id}\t{row.component_id}\t{row.name}\t{value}\t{row.mav_type}")
    return "\n".join(lines) + "\n"
