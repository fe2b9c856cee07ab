"""Parameter protocol over real UDP, as MAVSDK and QGC use it (bytewise PX4 encoding)."""

from __future__ import annotations

import pytest
from mavlink_fakes import has
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.params import (
    MAV_PARAM_TYPE_INT32,
    MAV_PARAM_TYPE_REAL32,
    PARAM_ERROR_DOES_NOT_EXIST,
    PARAM_ERROR_TYPE_MISMATCH,
    PARAM_ERROR_VALUE_OUT_OF_RANGE,
    decode_param_value,
    encode_param_value,
)

pytestmark = pytest.mark.sockets


def _only(inbox, type_name):
    found = [m for m in inbox if m.get_type() == type_name]
    assert len(found) == 1, [m.get_type() for m in inbox]
    return found[0]


def _read(client, endpoint, name, index=-1):
    client.send(
        endpoint,
        mavlink2.MAVLink_param_request_read_message(1, 1, name.encode(), index),
    )
    inbox = client.exchange(endpoint, 0.0, lambda i: has("PARAM_VALUE")(i) or has("PARAM_ERROR")(i))
    return next(m for m in inbox if m.get_type() in ("PARAM_VALUE", "PARAM_ERROR"))


def _set(client, endpoint, name, value, mav_type):
    client.send(
        endpoint,
        mavlink2.MAVLink_param_set_message(
            1, 1, name.encode(), encode_param_value(value, mav_type), mav_type
        ),
    )
    inbox = client.exchange(endpoint, 0.0, lambda i: has("PARAM_VALUE")(i) or has("PARAM_ERROR")(i))
    return next(m for m in inbox if m.get_type() in ("PARAM_VALUE", "PARAM_ERROR"))


def test_get_float_param_by_name(client, endpoint, vehicle):
    reply = _read(client, endpoint, "MIS_TAKEOFF_ALT")
    assert reply.get_type() == "PARAM_VALUE"
    assert reply.param_id == "MIS_TAKEOFF_ALT"
    assert reply.param_type == MAV_PARAM_TYPE_REAL32
    assert reply.param_value == 2.5
    assert reply.param_count == vehicle.params.count
    assert reply.param_index == vehicle.params.index_of("MIS_TAKEOFF_ALT")


def test_set_float_param_echoes_the_stored_value(client, endpoint, vehicle):
    reply = _set(client, endpoint, "MIS_TAKEOFF_ALT", 7.5, MAV_PARAM_TYPE_REAL32)
    assert (reply.get_type(), reply.param_id, reply.param_value) == (
        "PARAM_VALUE",
        "MIS_TAKEOFF_ALT",
        7.5,
    )
    assert reply.param_type == MAV_PARAM_TYPE_REAL32
    assert vehicle.params.get("MIS_TAKEOFF_ALT") == 7.5
    assert _read(client, endpoint, "MIS_TAKEOFF_ALT").param_value == 7.5


def test_int32_param_travels_bytewise(client, endpoint, vehicle):
    """INT32 values are memcpy'd into param_value both ways (PX4 encoding, not a float cast)."""
    reply = _read(client, endpoint, "SYS_AUTOSTART")
    assert reply.param_type == MAV_PARAM_TYPE_INT32
    assert reply.param_value != 6011.0
    assert decode_param_value(reply.param_value, MAV_PARAM_TYPE_INT32) == 6011

    reply = _set(client, endpoint, "NAV_RCL_ACT", 3, MAV_PARAM_TYPE_INT32)
    assert reply.get_type() == "PARAM_VALUE"
    assert reply.param_type == MAV_PARAM_TYPE_INT32
    assert decode_param_value(reply.param_value, MAV_PARAM_TYPE_INT32) == 3
    assert vehicle.params.get("NAV_RCL_ACT") == 3


def test_read_by_index(client, endpoint, vehicle):
    index = 5
    reply = _read(client, endpoint, "", index)
    assert reply.param_index == index
    assert reply.param_id == vehicle.params.name_at(index)


def test_read_unknown_name_or_index_gives_param_error(client, endpoint, vehicle):
    reply = _read(client, endpoint, "NO_SUCH_PARAM")
    assert reply.get_type() == "PARAM_ERROR"
    assert (reply.param_id, reply.param_index) == ("NO_SUCH_PARAM", -1)
    assert reply.error == PARAM_ERROR_DOES_NOT_EXIST
    assert (reply.target_system, reply.target_component) == (245, 190)

    reply = _read(client, endpoint, "", vehicle.params.count)
    assert reply.get_type() == "PARAM_ERROR"
    assert reply.param_index == vehicle.params.count
    assert reply.error == PARAM_ERROR_DOES_NOT_EXIST


def test_set_unknown_name_gives_param_error(client, endpoint):
    reply = _set(client, endpoint, "NO_SUCH_PARAM", 1.0, MAV_PARAM_TYPE_REAL32)
    assert reply.get_type() == "PARAM_ERROR"
    assert reply.error == PARAM_ERROR_DOES_NOT_EXIST
    assert reply.param_id == "NO_SUCH_PARAM"


def test_set_out_of_range_gives_param_error_and_keeps_the_value(client, endpoint, vehicle):
    reply = _set(client, endpoint, "MIS_TAKEOFF_ALT", 1000.0, MAV_PARAM_TYPE_REAL32)
    assert reply.get_type() == "PARAM_ERROR"
    assert reply.error == PARAM_ERROR_VALUE_OUT_OF_RANGE
    assert vehicle.params.get("MIS_TAKEOFF_ALT") == 2.5
    assert vehicle.params.version == 0

    reply = _set(client, endpoint, "MIS_TAKEOFF_ALT", float("nan"), MAV_PARAM_TYPE_REAL32)
    assert reply.error == PARAM_ERROR_VALUE_OUT_OF_RANGE
    assert vehicle.params.get("MIS_TAKEOFF_ALT") == 2.5


def test_set_with_the_wrong_type_gives_type_mismatch(client, endpoint, vehicle):
    reply = _set(client, endpoint, "SYS_AUTOSTART", 4001.0, MAV_PARAM_TYPE_REAL32)
    assert reply.get_type() == "PARAM_ERROR"
    assert reply.error == PARAM_ERROR_TYPE_MISMATCH
    assert vehicle.params.get("SYS_AUTOSTART") == 6011


def test_request_list_streams_every_parameter(client, endpoint, vehicle):
    """PARAM_REQUEST_LIST: every index 0..count-1 arrives once, with name and count."""
    client.send(endpoint, mavlink2.MAVLink_param_request_list_message(1, 1))
    values = []
    for poll in range(20):
        endpoint.poll(poll * 0.001)
        values += [m for m in client.drain() if m.get_type() == "PARAM_VALUE"]
        if len(values) >= vehicle.params.count:
            break
    assert sorted(v.param_index for v in values) == list(range(vehicle.params.count))
    assert all(v.param_count == vehicle.params.count for v in values)
    assert [v.param_id for v in sorted(values, key=lambda v: v.param_index)] == list(
        vehicle.params.names
    )
    assert poll > 0  # spread over several polls


def test_messages_for_another_system_are_ignored(client, endpoint, vehicle):
    client.send(
        endpoint,
        mavlink2.MAVLink_param_set_message(2, 1, b"MIS_TAKEOFF_ALT", 5.0, MAV_PARAM_TYPE_REAL32),
    )
    client.send(endpoint, mavlink2.MAVLink_param_request_read_message(2, 1, b"MIS_TAKEOFF_ALT", -1))
    reply = _read(client, endpoint, "MAV_SYS_ID")
    assert reply.param_id == "MAV_SYS_ID"
    assert [m.get_type() for m in client.inbox].count("PARAM_VALUE") == 1
    assert vehicle.params.get("MIS_TAKEOFF_ALT") == 2.5


def test_sixteen_character_names_work(client, endpoint, vehicle):
    assert "COM_DISARM_PRFLT" in vehicle.params.names and len("COM_DISARM_PRFLT") == 16
    reply = _read(client, endpoint, "COM_DISARM_PRFLT")
    assert (reply.param_id, reply.param_value) == ("COM_DISARM_PRFLT", 10.0)


def test_a_client_set_is_noted_for_saving_and_a_refused_one_is_not(client, endpoint, vehicle):
    """PARAM_SET that stores a value puts the name in client_set (what a run saves on exit);
    refused sets (range, type) and the autopilot's own writes do not."""
    _set(client, endpoint, "MIS_TAKEOFF_ALT", 7.5, MAV_PARAM_TYPE_REAL32)
    _set(client, endpoint, "RTL_RETURN_ALT", 1000.0, MAV_PARAM_TYPE_REAL32)  # out of range
    _set(client, endpoint, "SYS_AUTOSTART", 4001.0, MAV_PARAM_TYPE_REAL32)  # wrong type
    _set(client, endpoint, "BAT1_N_CELLS", 6, MAV_PARAM_TYPE_INT32)
    vehicle.params.set("EKF2_MAG_DECL", 3.0)
    assert vehicle.params.client_set == tuple(
        sorted(("MIS_TAKEOFF_ALT", "BAT1_N_CELLS"), key=vehicle.params.index_of)
    )
