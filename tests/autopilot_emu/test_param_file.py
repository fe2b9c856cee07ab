"""QGroundControl .params files: what we write reads back exactly; bad lines are named."""

from __future__ import annotations

import struct

import pytest

from autopilot_emu.param_file import (
    COLUMNS_COMMENT,
    ParamFileError,
    format_param_file,
    format_value,
    parse_param_file,
    read_param_file,
    store_rows,
)
from autopilot_emu.params import MAV_PARAM_TYPE_INT32, MAV_PARAM_TYPE_REAL32, ParamStore

# QGroundControl 4.x "Save to file" of a PX4 vehicle: its header, 18-decimal floats, and a row of
# another component (a camera's parameter, component 100).
QGC_SAVED = (
    "# Onboard parameters for Vehicle 1\n"
    "#\n"
    "# Stack: PX4 Pro\n"
    "# Vehicle: Multi-Rotor\n"
    "# Version: 1.14.0 dev\n"
    "# Git Revision: 1c8ab2a0d7000000\n"
    "#\n"
    "# Vehicle-Id Component-Id Name Value Type\n"
    "1\t1\tBAT1_N_CELLS\t6\t6\n"
    "1\t1\tBAT_LOW_THR\t0.150000005960464478\t9\n"
    "1\t1\tMPC_XY_CRUISE\t7.500000000000000000\t9\n"
    "1\t100\tCAM_EV_STEPS\t3\t6\n"
)


def _float32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def test_a_qgroundcontrol_file_reads_into_typed_rows():
    rows = parse_param_file(QGC_SAVED, "saved.params")
    by_name = {r.name: r for r in rows}
    assert by_name["BAT1_N_CELLS"].value == 6
    assert isinstance(by_name["BAT1_N_CELLS"].value, int)
    assert by_name["BAT_LOW_THR"].value == _float32(0.15)  # 18 decimals: the same float32
    assert by_name["MPC_XY_CRUISE"].value == 7.5
    assert [(r.vehicle_id, r.component_id, r.line) for r in rows] == [
        (1, 1, 9),
        (1, 1, 10),
        (1, 1, 11),
        (1, 100, 12),
    ]


def test_every_parameter_round_trips_bit_exactly_through_the_text():
    """Write a store whose values need all nine float32 digits, read it back: the same values,
    types and float32 bit patterns (a reload changes nothing)."""
    store = ParamStore()
    store.set("MC_ROLLRATE_D", 0.0031234567)
    store.set("BAT_LOW_THR", 0.13)
    store.set("MIS_TAKEOFF_ALT", 12.345678)
    store.set("EKF2_MAG_DECL", -3.0e-5)
    store.set("BAT1_N_CELLS", 6)
    text = format_param_file(store_rows(3, store), comments=("test",))
    rows = parse_param_file(text)
    assert len(rows) == store.count
    for row in rows:
        assert (row.vehicle_id, row.component_id) == (3, 1)
        assert row.mav_type == store.type_of(row.name)
        assert struct.pack("<f", row.value) == struct.pack("<f", store.get(row.name)), row
        assert type(row.value) is type(store.get(row.name))


def test_written_rows_have_qgroundcontrols_columns_and_type_codes():
    store = ParamStore()
    text = format_param_file(store_rows(2, store, ["BAT_LOW_THR", "SYS_AUTOSTART"]))
    lines = text.splitlines()
    assert lines[0] == "# Onboard parameters for Vehicle 2"
    assert COLUMNS_COMMENT in lines
    assert lines[-2:] == ["2\t1\tBAT_LOW_THR\t0.15\t9", "2\t1\tSYS_AUTOSTART\t6011\t6"]


@pytest.mark.parametrize(
    ("value", "mav_type", "text"),
    [
        (1.0, MAV_PARAM_TYPE_REAL32, "1"),
        (_float32(0.3), MAV_PARAM_TYPE_REAL32, "0.3"),
        (_float32(1.0e-7), MAV_PARAM_TYPE_REAL32, "0.0000001"),
        (-4194304, MAV_PARAM_TYPE_INT32, "-4194304"),
    ],
)
def test_values_are_written_as_the_shortest_exact_decimal(value, mav_type, text):
    assert format_value(value, mav_type) == text


def test_space_separated_rows_are_read_too():
    rows = parse_param_file("1 1 MPC_XY_CRUISE 6.5 9\n")
    assert rows[0].value == 6.5


HEAD = "# Vehicle-Id Component-Id Name Value Type\n1\t1\tMPC_XY_CRUISE\t6\t9\n"


@pytest.mark.parametrize(
    ("line", "says"),
    [
        ("1\t1\tNO_SUCH_PARAM\t1\t9", "unknown parameter 'NO_SUCH_PARAM'"),
        ("1\t1\tMPC_XY_CRUSE\t6\t9", "'MPC_XY_CRUSE'; did you mean MPC_XY_CRUISE"),
        ("1\t1\tMPC_XY_CRUISE\t6\t6", "MPC_XY_CRUISE is REAL32 (type 9), the line gives type 6"),
        ("1\t1\tSYS_AUTOSTART\t4001\t9", "SYS_AUTOSTART is INT32 (type 6)"),
        ("1\t1\tBAT1_N_CELLS\t4", "expected 5 tab-separated fields"),
        ("1\t1\tBAT1_N_CELLS\t4\t6\textra", "got 6"),
        ("1\t1\tSYS_AUTOSTART\t2147483648\t6", "outside the INT32 range"),
        ("1\t1\tSYS_AUTOSTART\t-2147483649\t6", "outside the INT32 range"),
        ("1\t1\tBAT1_N_CELLS\t4.5\t6", "is not an integer"),
        ("1\t1\tMPC_XY_CRUISE\tfast\t9", "is not a number"),
        ("1\t1\tMPC_XY_CRUISE\tnan\t9", "not finite"),
        ("1\t1\tMPC_XY_CRUISE\t100\t9", "outside [3.0, 20.0]"),
        ("1\t1\tBAT1_N_CELLS\t99\t6", "outside"),
        ("0\t1\tMPC_XY_CRUISE\t6\t9", "Vehicle-Id must be an integer 1..255"),
        ("x\t1\tMPC_XY_CRUISE\t6\t9", "Vehicle-Id"),
        ("1\t1\tMPC_XY_CRUISE\t6\t11", "Type (MAV_PARAM_TYPE)"),
        ("1\t100\tCAM_EV_STEPS\tthree\t6", "is not a number"),
        ("1\t1\tA_NAME_LONGER_THAN_16\t1\t9", "not 1..16 ASCII"),
    ],
)
def test_a_bad_line_is_refused_naming_file_and_line(line, says):
    text = HEAD + "\n# a comment\n" + line + "\n1\t1\tMPC_XY_CRUISE\t6\t9\n"
    with pytest.raises(ParamFileError) as info:
        parse_param_file(text, "my.params")
    assert info.value.line == 5
    assert str(info.value).startswith("my.params:5: ")
    assert says in str(info.value)


def test_a_missing_file_is_named(tmp_path):
    path = tmp_path / "nope.params"
    with pytest.raises(ParamFileError) as info:
        read_param_file(path)
    assert info.value.line is None
    assert str(info.value).startswith(f"{path}: ")


def test_a_binary_file_names_the_line_of_the_first_bad_byte(tmp_path):
    path = tmp_path / "bin.params"
    path.write_bytes(b"# ok\n1\t1\tMPC_XY_CRUISE\t6\t9\n\xff\xfe\n")
    with pytest.raises(ParamFileError) as info:
        read_param_file(path)
    assert info.value.line == 3
