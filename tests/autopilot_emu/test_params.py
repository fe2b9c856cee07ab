"""ParamStore, the packaged PX4 table and the bytewise wire encoding."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from autopilot_emu.params import (
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
    PARAM_ERROR_DOES_NOT_EXIST,
    PARAM_ERROR_TYPE_MISMATCH,
    PARAM_ERROR_VALUE_OUT_OF_RANGE,
    ParamError,
    ParamStore,
    decode_param_value,
    encode_param_value,
    load_param_specs,
    parse_param_specs,
)

REQUIRED = {
    "MIS_TAKEOFF_ALT": ("REAL32", 2.5),
    "RTL_RETURN_ALT": ("REAL32", 30.0),
    "MPC_XY_CRUISE": ("REAL32", 5.0),
    "MPC_THR_HOVER": ("REAL32", 0.5),
    "MC_ROLLRATE_D": ("REAL32", 0.003),
    "COM_DISARM_LAND": ("REAL32", 2.0),
    "COM_OBL_RC_ACT": ("INT32", 0),
    "COM_RC_IN_MODE": ("INT32", 1),
    "NAV_RCL_ACT": ("INT32", 2),
    "NAV_DLL_ACT": ("INT32", 0),
    "SYS_AUTOSTART": ("INT32", 6011),
    "MAV_SYS_ID": ("INT32", 1),
    "BAT1_N_CELLS": ("INT32", 4),
    "CAL_ACC0_ID": ("INT32", 1310988),
    "CAL_MAG0_ID": ("INT32", 197388),
    "SDLOG_MODE": ("INT32", 0),
}


def _entry(**overrides: object) -> dict:
    entry = {
        "name": "TEST_P",
        "type": "REAL32",
        "default": 1.0,
        "min": 0.0,
        "max": 2.0,
        "unit": "m",
        "description": "test",
    }
    entry.update(overrides)
    return entry


def test_packaged_table_has_px4_names_types_and_defaults():
    """The YAML carries the PX4 names with their fixed types and defaults."""
    store = ParamStore()
    for name, (type_name, default) in REQUIRED.items():
        expected_type = MAV_PARAM_TYPE_INT32 if type_name == "INT32" else MAV_PARAM_TYPE_REAL32
        assert store.type_of(name) == expected_type, name
        assert store.get(name) == pytest.approx(default, rel=1e-6), name
        if type_name == "INT32":
            assert type(store.get(name)) is int
    assert all(len(spec.name) <= 16 for spec in load_param_specs())
    assert all(spec.min_value <= spec.default <= spec.max_value for spec in load_param_specs())


def test_index_order_is_stable_and_consistent():
    """names, index_of and name_at agree and follow the YAML order."""
    store = ParamStore()
    assert store.count == len(store.names) == len(load_param_specs())
    for index, name in enumerate(store.names):
        assert store.index_of(name) == index
        assert store.name_at(index) == name
    assert ParamStore().names == store.names
    with pytest.raises(ParamError) as info:
        store.name_at(store.count)
    assert info.value.code == PARAM_ERROR_DOES_NOT_EXIST


def test_set_returns_float32_rounded_value_and_bumps_version():
    """REAL32 values are stored as float32; version counts real changes only."""
    store = ParamStore()
    assert store.version == 0
    stored = store.set("MIS_TAKEOFF_ALT", 0.1)
    assert stored == struct.unpack("<f", struct.pack("<f", 0.1))[0]
    assert store.get("MIS_TAKEOFF_ALT") == stored
    assert store.version == 1
    store.set("MIS_TAKEOFF_ALT", 0.1)
    assert store.version == 1
    assert store.set("NAV_RCL_ACT", np.int64(3)) == 3
    assert type(store.get("NAV_RCL_ACT")) is int
    assert store.version == 2
    assert store.set("MIS_TAKEOFF_ALT", 4) == 4.0


@pytest.mark.parametrize(
    ("name", "value", "code"),
    [
        ("NO_SUCH_PARAM", 1.0, PARAM_ERROR_DOES_NOT_EXIST),
        ("MIS_TAKEOFF_ALT", 500.0, PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("MIS_TAKEOFF_ALT", -1.0, PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("MIS_TAKEOFF_ALT", math.nan, PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("MIS_TAKEOFF_ALT", math.inf, PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("MIS_TAKEOFF_ALT", 1e300, PARAM_ERROR_VALUE_OUT_OF_RANGE),
        ("MIS_TAKEOFF_ALT", "3", PARAM_ERROR_TYPE_MISMATCH),
        ("NAV_RCL_ACT", 2.0, PARAM_ERROR_TYPE_MISMATCH),
        ("NAV_RCL_ACT", True, PARAM_ERROR_TYPE_MISMATCH),
        ("NAV_RCL_ACT", 99, PARAM_ERROR_VALUE_OUT_OF_RANGE),
    ],
)
def test_set_rejects_with_mav_param_error_code(name, value, code):
    """Bad writes raise ParamError with the MAV_PARAM_ERROR code and change nothing."""
    store = ParamStore()
    before = [store.get(n) for n in store.names]
    with pytest.raises(ParamError) as info:
        store.set(name, value)
    assert info.value.code == code
    assert [store.get(n) for n in store.names] == before
    assert store.version == 0


def test_unknown_name_lookups_raise_does_not_exist():
    store = ParamStore()
    for call in (store.get, store.type_of, store.index_of, store.spec):
        with pytest.raises(ParamError) as info:
            call("NOPE")
        assert info.value.code == PARAM_ERROR_DOES_NOT_EXIST


def test_an_unknown_name_gets_the_close_names_or_where_the_table_is():
    with pytest.raises(
        ParamError, match=r"unknown parameter 'MPC_XY_CRUSE'; did you mean MPC_XY_CRUISE"
    ):
        ParamStore({"MPC_XY_CRUSE": 6.0})
    with pytest.raises(
        ParamError, match=r"'QQQQ' \(this autopilot's are in autopilot_emu/px4_params"
    ):
        ParamStore().get("QQQQ")


def test_overrides_apply_and_are_validated():
    """Overrides replace defaults; a bad override fails construction."""
    store = ParamStore({"MAV_SYS_ID": 3, "MIS_TAKEOFF_ALT": 10.0})
    assert store.get("MAV_SYS_ID") == 3
    assert store.get("MIS_TAKEOFF_ALT") == 10.0
    assert store.version == 0
    assert ParamStore().get("MAV_SYS_ID") == 1
    with pytest.raises(ParamError):
        ParamStore({"MAV_SYS_ID": 0})


@pytest.mark.parametrize("value", [0, 1, -1, 6011, 1310988, 2**31 - 1, -(2**31), 2139095040])
def test_int32_bytewise_round_trip(value):
    """INT32 bytes are memcpy'd into the float field and recovered exactly."""
    raw = encode_param_value(value, MAV_PARAM_TYPE_INT32)
    assert struct.pack("<f", raw) == struct.pack("<i", value)
    assert decode_param_value(raw, MAV_PARAM_TYPE_INT32) == value


def test_int32_one_is_a_denormal_not_one_point_zero():
    raw = encode_param_value(1, MAV_PARAM_TYPE_INT32)
    assert raw != 1.0
    assert 0.0 < raw < 1e-44


def test_real32_encoding_is_plain_float():
    assert encode_param_value(2.5, MAV_PARAM_TYPE_REAL32) == 2.5
    assert decode_param_value(2.5, MAV_PARAM_TYPE_REAL32) == 2.5


def test_encoding_rejects_bad_input():
    with pytest.raises(ValueError):
        encode_param_value(2**31, MAV_PARAM_TYPE_INT32)
    with pytest.raises(TypeError):
        encode_param_value(1.5, MAV_PARAM_TYPE_INT32)
    with pytest.raises(ValueError):
        encode_param_value(1.0, 10)
    with pytest.raises(ValueError):
        decode_param_value(1.0, 10)


@pytest.mark.parametrize(
    "entry",
    [
        _entry(name="A_NAME_LONGER_THAN_16"),
        _entry(type="UINT8"),
        _entry(default=3.0),
        _entry(type="INT32", default=1.5, min=0, max=2),
        _entry(min="0"),
        _entry(type="INT32", default=0, min=0, max=2**31 - 1),
        {"name": "X"},
    ],
)
def test_table_validation_rejects_bad_entries(entry):
    with pytest.raises(ValueError):
        parse_param_specs({"params": [entry]})


def test_table_validation_rejects_duplicates_and_empty_tables():
    with pytest.raises(ValueError):
        parse_param_specs({"params": [_entry(), _entry()]})
    with pytest.raises(ValueError):
        parse_param_specs({"params": []})


def test_spec_exposes_unit_and_description():
    spec = ParamStore().spec("MIS_TAKEOFF_ALT")
    assert spec.unit == "m"
    assert spec.description
    assert spec.min_value == 0.0


def test_float_view_follows_every_change():
    store = ParamStore({"MIS_TAKEOFF_ALT": 4.0})
    floats = store.floats()
    assert floats["MIS_TAKEOFF_ALT"] == 4.0
    assert isinstance(floats["COM_OBL_RC_ACT"], float)
    assert store.floats() is floats  # kept while nothing changes
    store.set("MIS_TAKEOFF_ALT", 4.0)  # same value: no change
    assert store.floats() is floats
    store.set("MIS_TAKEOFF_ALT", 7.5)
    assert store.floats()["MIS_TAKEOFF_ALT"] == 7.5
    assert store.floats()["COM_OBL_RC_ACT"] == float(store.get("COM_OBL_RC_ACT"))
