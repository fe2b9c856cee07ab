"""COMMAND_LONG / COMMAND_INT handling over UDP, and the dispatcher's retransmission filter."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from mavlink_fakes import HOME, FakeVehicle, MavClient, command_long, has
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.commands import (
    DUPLICATE_WINDOW_S,
    CommandDispatcher,
    CommandRequest,
)
from autopilot_emu.mavlink.messages import CAPABILITIES
from autopilot_emu.mavlink.streams import PROFILES, StreamProfile

pytestmark = pytest.mark.sockets

ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
DENIED = mavlink2.MAV_RESULT_DENIED
UNSUPPORTED = mavlink2.MAV_RESULT_UNSUPPORTED
FAILED = mavlink2.MAV_RESULT_FAILED


def _acks(inbox):
    return [m for m in inbox if m.get_type() == "COMMAND_ACK"]


def _command(client, endpoint, msg, now_s=0.0):
    """Send one command and return its ACK."""
    client.send(endpoint, msg)
    return _acks(client.exchange(endpoint, now_s, has("COMMAND_ACK")))[0]


def _command_int(command, frame, x, y, z, *params):
    padded = list(params) + [math.nan] * (4 - len(params))
    return mavlink2.MAVLink_command_int_message(1, 1, frame, command, 0, 0, *padded, x, y, z)


def test_ack_is_addressed_to_the_sender_from_our_ids(client, endpoint, vehicle):
    ack = _command(client, endpoint, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1))
    assert (ack.command, ack.result) == (mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, ACCEPTED)
    assert (ack.target_system, ack.target_component) == (245, 190)
    assert (ack.get_srcSystem(), ack.get_srcComponent()) == (1, 1)
    assert vehicle.calls == [("arm", False)]


def test_duplicated_command_is_acked_twice_but_executed_once(client, endpoint, vehicle):
    """A retransmission (same source, id and params) is re-ACKed from the cache."""
    takeoff = command_long(mavlink2.MAV_CMD_NAV_TAKEOFF)
    client.send(endpoint, takeoff)
    client.send(endpoint, takeoff)
    acks = _acks(client.exchange(endpoint, 0.0, has("COMMAND_ACK", 2)))
    assert [a.result for a in acks] == [ACCEPTED, ACCEPTED]
    assert vehicle.calls == [("takeoff", None)]
    assert endpoint.stats.commands_handled == 1
    assert endpoint.stats.commands_duplicate == 1


def test_duplicate_detection_ignores_confirmation_but_not_params_or_source(
    client, endpoint, vehicle
):
    arm = command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1, confirmation=0)
    retry = command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1, confirmation=1)
    forced = command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196)
    other = MavClient(sysid=246, compid=190)
    try:
        for msg in (arm, retry, forced):
            _command(client, endpoint, msg)
        _command(other, endpoint, arm)
    finally:
        other.close()
    assert vehicle.calls == [("arm", False), ("arm", True), ("arm", False)]
    assert endpoint.stats.commands_duplicate == 1


def test_accepted_result_is_replayed_for_a_duplicate(client, endpoint, vehicle):
    arm = command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert _command(client, endpoint, arm).result == ACCEPTED
    vehicle.result = DENIED
    assert _command(client, endpoint, arm).result == ACCEPTED
    assert vehicle.calls == [("arm", False)]


def test_refused_command_is_executed_again_when_repeated(client, endpoint, vehicle):
    """A refusal has no side effect, and the vehicle may have become ready since."""
    vehicle.result = DENIED
    disarm = command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    assert _command(client, endpoint, disarm).result == DENIED
    vehicle.result = ACCEPTED
    assert _command(client, endpoint, disarm).result == ACCEPTED
    assert vehicle.calls == [("disarm", False), ("disarm", False)]


def test_unknown_command_is_unsupported(client, endpoint, vehicle):
    ack = _command(client, endpoint, command_long(31000, 1, 2, 3))
    assert (ack.command, ack.result) == (31000, UNSUPPORTED)
    assert vehicle.calls == []


def test_command_for_another_system_or_component_is_ignored(client, endpoint, vehicle):
    """No ACK, no effect; a later command proves the earlier ones were processed."""
    client.send(endpoint, command_long(mavlink2.MAV_CMD_NAV_LAND, target_system=2))
    client.send(endpoint, command_long(mavlink2.MAV_CMD_NAV_LAND, target_component=100))
    client.send(endpoint, command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 148))
    acks = _acks(client.exchange(endpoint, 0.0, has("AUTOPILOT_VERSION")))
    assert [a.command for a in acks] == [mavlink2.MAV_CMD_REQUEST_MESSAGE]
    assert vehicle.calls == []
    assert endpoint.stats.commands_ignored == 2


def test_broadcast_target_is_accepted(client, endpoint, vehicle):
    ack = _command(
        client,
        endpoint,
        command_long(mavlink2.MAV_CMD_NAV_LAND, target_system=0, target_component=0),
    )
    assert ack.result == ACCEPTED
    assert vehicle.calls == [("land",)]


@pytest.mark.parametrize(
    "msg",
    [
        command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM),  # param1 NaN
        command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, math.inf),
        command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0.5 + 2),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, math.nan, 0),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 0, 4, 3),  # no CUSTOM_MODE_ENABLED
        command_long(mavlink2.MAV_CMD_NAV_TAKEOFF, *[math.nan] * 6, math.inf),
        command_long(mavlink2.MAV_CMD_DO_REPOSITION, -1, 1, 0, 0, math.inf, 8.5, 500),
        command_long(mavlink2.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, math.nan, 8.5, 500),
        command_long(mavlink2.MAV_CMD_DO_FLIGHTTERMINATION),
        command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 30),  # interval NaN
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE),
    ],
)
def test_nan_or_inf_where_a_number_is_required_is_denied(client, endpoint, vehicle, msg):
    assert _command(client, endpoint, msg).result == DENIED
    assert vehicle.calls == []


def test_set_mode_ignores_the_armed_bit(client, endpoint, vehicle):
    for base in (1, 129):
        _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_SET_MODE, base, 4, 3))
        _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_SET_MODE, base, 6, 0))
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 3))
    assert vehicle.calls == [("set_mode", 4, 3), ("set_mode", 6, 0)] * 2 + [("set_mode", 3, 0)]


def test_arm_disarm_and_kill(client, endpoint, vehicle):
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1))
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0))
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196))
    assert vehicle.calls == [("arm", False), ("disarm", False), ("disarm", True)]


def test_vehicle_result_is_passed_through(client, endpoint, vehicle):
    vehicle.result = mavlink2.MAV_RESULT_TEMPORARILY_REJECTED
    ack = _command(client, endpoint, command_long(mavlink2.MAV_CMD_NAV_TAKEOFF))
    assert ack.result == mavlink2.MAV_RESULT_TEMPORARILY_REJECTED


def test_vehicle_exception_becomes_failed(client, endpoint, vehicle):
    def explode() -> int:
        raise RuntimeError("boom")

    vehicle.land = explode
    ack = _command(client, endpoint, command_long(mavlink2.MAV_CMD_NAV_LAND))
    assert ack.result == FAILED


def test_takeoff_with_an_altitude(client, endpoint, vehicle):
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_NAV_TAKEOFF, *[math.nan] * 6, 510))
    assert vehicle.calls == [("takeoff", 510.0)]


def test_reposition_global_int_as_mavsdk_goto_location(client, endpoint, vehicle):
    """MAVSDK goto_location: COMMAND_INT, frame GLOBAL_INT, degE7, AMSL z, yaw in rad."""
    msg = _command_int(
        mavlink2.MAV_CMD_DO_REPOSITION,
        mavlink2.MAV_FRAME_GLOBAL_INT,
        473978000,
        85457000,
        500.0,
        math.nan,
        1,
        math.nan,
        math.pi / 2,
    )
    assert _command(client, endpoint, msg).result == ACCEPTED
    ((name, lat, lon, alt, yaw, speed),) = vehicle.calls
    assert name == "reposition"
    assert lat == pytest.approx(47.3978) and lon == pytest.approx(8.5457)
    assert alt == 500.0
    assert yaw == pytest.approx(math.pi / 2)
    assert math.isnan(speed)


def test_reposition_relative_frame_uses_home_altitude_and_nan_keeps(client, endpoint, vehicle):
    msg = _command_int(
        mavlink2.MAV_CMD_DO_REPOSITION,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        2**31 - 1,
        2**31 - 1,
        10.0,
        5.0,
    )
    assert _command(client, endpoint, msg).result == ACCEPTED
    ((_, lat, lon, alt, yaw, speed),) = vehicle.calls
    assert math.isnan(lat) and math.isnan(lon) and math.isnan(yaw)
    assert alt == pytest.approx(HOME.alt_amsl_m + 10.0)
    assert speed == 5.0


def test_reposition_relative_without_home_and_unknown_frames_are_denied(client, endpoint, vehicle):
    vehicle.snapshot = replace(vehicle.snapshot, home=None)
    relative = _command_int(
        mavlink2.MAV_CMD_DO_REPOSITION, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0, 0, 10.0
    )
    assert _command(client, endpoint, relative).result == DENIED
    local = _command_int(mavlink2.MAV_CMD_DO_REPOSITION, mavlink2.MAV_FRAME_LOCAL_NED, 0, 0, 1.0)
    assert _command(client, endpoint, local).result == DENIED
    assert vehicle.calls == []


def test_change_speed_set_home_and_terminate(client, endpoint, vehicle):
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 7.5, -1, 0))
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_SET_HOME, 1))
    _command(
        client, endpoint, command_long(mavlink2.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 47.4, 8.5, 490)
    )
    _command(client, endpoint, command_long(mavlink2.MAV_CMD_DO_FLIGHTTERMINATION, 1))
    assert vehicle.calls[0] == ("change_speed", 7.5)
    assert vehicle.calls[1][:2] == ("set_home", True)
    assert vehicle.calls[2] == ("set_home", False, pytest.approx(47.4), pytest.approx(8.5), 490)
    assert vehicle.calls[3] == ("terminate",)


def test_reboot_is_acknowledged_without_effect(client, endpoint, vehicle):
    client.send(endpoint, command_long(mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1))
    inbox = client.exchange(endpoint, 0.0, lambda i: has("COMMAND_ACK")(i) and has("STATUSTEXT")(i))
    assert _acks(inbox)[0].result == ACCEPTED
    assert "reboot" in next(m for m in inbox if m.get_type() == "STATUSTEXT").text
    assert vehicle.calls == []


@pytest.mark.parametrize(
    "msg",
    [
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION),
        command_long(mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1),
    ],
)
def test_autopilot_version_request(client, endpoint, msg):
    """AUTOPILOT_VERSION follows the ACK and advertises MISSION_INT (MAVSDK needs it)."""
    client.send(endpoint, msg)
    inbox = client.exchange(endpoint, 0.0, has("AUTOPILOT_VERSION"))
    types = [m.get_type() for m in inbox]
    assert types.index("COMMAND_ACK") < types.index("AUTOPILOT_VERSION")
    assert _acks(inbox)[0].result == ACCEPTED
    version = next(m for m in inbox if m.get_type() == "AUTOPILOT_VERSION")
    assert version.capabilities & mavlink2.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert version.capabilities & mavlink2.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert not version.capabilities & mavlink2.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    assert version.capabilities == CAPABILITIES == 59871
    assert version.flight_sw_version == (1 << 24) | (15 << 16) | (0 << 8) | 0xFF
    assert version.uid & 0xFF == 1


def test_home_position_request_needs_a_home(client, endpoint, vehicle):
    for msg in (
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, mavlink2.MAVLINK_MSG_ID_HOME_POSITION),
        command_long(mavlink2.MAV_CMD_GET_HOME_POSITION),
    ):
        client.send(endpoint, msg)
        inbox = client.exchange(endpoint, 0.0, has("HOME_POSITION"))
        home = next(m for m in inbox if m.get_type() == "HOME_POSITION")
        assert home.latitude == round(HOME.lat_deg * 1e7)
        assert home.altitude == round(HOME.alt_amsl_m * 1000)
    vehicle.snapshot = replace(vehicle.snapshot, home=None)
    ack = _command(
        client,
        endpoint,
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, mavlink2.MAVLINK_MSG_ID_HOME_POSITION),
    )
    assert ack.result == DENIED


def test_request_of_a_streamed_or_unknown_message(client, endpoint):
    client.send(endpoint, command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 245))
    inbox = client.exchange(endpoint, 0.0, has("EXTENDED_SYS_STATE"))
    assert _acks(inbox)[0].result == ACCEPTED
    assert (
        _command(client, endpoint, command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 9999)).result
        == DENIED
    )


def test_get_message_interval(client, endpoint):
    client.send(endpoint, command_long(mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL, 33))
    inbox = client.exchange(endpoint, 0.0, has("MESSAGE_INTERVAL"))
    interval = next(m for m in inbox if m.get_type() == "MESSAGE_INTERVAL")
    onboard_rate_hz = PROFILES[StreamProfile.ONBOARD]["GLOBAL_POSITION_INT"]
    assert (interval.message_id, interval.interval_us) == (33, round(1e6 / onboard_rate_hz))


class _NoServices:
    def home_alt_amsl_m(self):
        return None


def test_retransmission_window_uses_the_wall_clock():
    """Inside the window a repeat is a duplicate; after it the command runs again."""
    wall = [100.0]
    vehicle = FakeVehicle()
    dispatcher = CommandDispatcher(vehicle, _NoServices(), wall_clock_s=lambda: wall[0])
    land = CommandRequest(21, (math.nan,) * 4, math.nan, math.nan, math.nan, None, (245, 190))
    assert not dispatcher.handle(land).duplicate
    wall[0] += DUPLICATE_WINDOW_S - 0.1
    assert dispatcher.handle(land).duplicate
    wall[0] += DUPLICATE_WINDOW_S + 0.1
    assert not dispatcher.handle(land).duplicate
    assert vehicle.calls == [("land",), ("land",)]


def _long_at(command, lat, lon, alt, *params):
    """COMMAND_LONG with param1..4 (NaN-padded) and a position in param5..7."""
    padded = list(params) + [math.nan] * (4 - len(params))
    return command_long(command, *padded, lat, lon, alt)


_INT32_MAX = 2**31 - 1


@pytest.mark.parametrize(
    "msg",
    [
        # DO_SET_HOME: the fuzz finding, then each bound and the use-current flag.
        _long_at(mavlink2.MAV_CMD_DO_SET_HOME, 1000, 2000, 500, 0),
        _long_at(mavlink2.MAV_CMD_DO_SET_HOME, 90.001, 8.5, 500, 0),
        _long_at(mavlink2.MAV_CMD_DO_SET_HOME, 47.4, -180.001, 500, 0),
        _long_at(mavlink2.MAV_CMD_DO_SET_HOME, 47.4, 8.5, math.inf, 0),
        _long_at(mavlink2.MAV_CMD_DO_SET_HOME, 47.4, 8.5, 500, 2),
        _command_int(
            mavlink2.MAV_CMD_DO_SET_HOME, mavlink2.MAV_FRAME_GLOBAL_INT, 950_000_000, 0, 500, 0
        ),
        # ARM_DISARM flag.
        command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, -1),
        command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 2),
        # DO_SET_MODE: base mode byte, PX4 main modes, AUTO sub modes, sub mode byte.
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 257, 4, 3),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, -1, 4, 3),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 0, 0),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 9, 0),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 1e9, 0),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 4, 7),  # AUTO_RTGS: reserved
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 4, 11),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 6, 256),
        command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1, 4, math.inf),
        # DO_CHANGE_SPEED: SPEED_TYPE, speed, throttle.
        command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 4, 5, -1, 0),
        command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, math.nan, 5, -1, 0),
        command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, -3, -1, 0),
        command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, math.inf, -1, 0),
        command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 5, 101, 0),
        # DO_REPOSITION: position range (both message kinds), flags, yaw.
        _long_at(mavlink2.MAV_CMD_DO_REPOSITION, 1000, 8.5, 500),
        _long_at(mavlink2.MAV_CMD_DO_REPOSITION, 47.4, 2000, 500),
        _command_int(
            mavlink2.MAV_CMD_DO_REPOSITION,
            mavlink2.MAV_FRAME_GLOBAL_INT,
            473978000,
            -1_900_000_000,
            500.0,
        ),
        _command_int(
            mavlink2.MAV_CMD_DO_REPOSITION,
            mavlink2.MAV_FRAME_GLOBAL_INT,
            _INT32_MAX,
            85457000,
            500.0,
        ),  # x alone "unset" is latitude 214.7 deg
        _long_at(mavlink2.MAV_CMD_DO_REPOSITION, 47.4, 8.5, 500, -1, 8),
        _long_at(mavlink2.MAV_CMD_DO_REPOSITION, 47.4, 8.5, 500, -1, 1, 0, math.inf),
        # NAV_TAKEOFF / NAV_LAND: coordinates and yaw.
        _long_at(mavlink2.MAV_CMD_NAV_TAKEOFF, 91, 8.5, math.nan),
        _long_at(mavlink2.MAV_CMD_NAV_TAKEOFF, math.nan, math.nan, math.nan, 0, 0, 0, math.inf),
        _long_at(mavlink2.MAV_CMD_NAV_LAND, 47.4, 181, math.nan),
        _long_at(mavlink2.MAV_CMD_NAV_LAND, math.nan, math.nan, -math.inf),
        _command_int(mavlink2.MAV_CMD_NAV_LAND, mavlink2.MAV_FRAME_LOCAL_NED, 0, 0, 0.0),
        # Termination and reboot actions.
        command_long(mavlink2.MAV_CMD_DO_FLIGHTTERMINATION, 0),
        command_long(mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 4),
        command_long(mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, -1),
        # Message ids: 24-bit for REQUEST_MESSAGE, 16-bit where MESSAGE_INTERVAL reports them.
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 0x1000000),
        command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, -1),
        command_long(mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL, 0x10000),
        command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 0x10000 + 30, 1000),
        # COMMAND_LONG param5/6 = INT32_MAX, COMMAND_INT x/y = NaN bits: denied by PX4's receiver.
        _long_at(mavlink2.MAV_CMD_NAV_LAND, float(2**31), float(2**31), math.nan),
        _command_int(
            mavlink2.MAV_CMD_NAV_LAND, mavlink2.MAV_FRAME_GLOBAL_INT, 0x7FF80000, 0x7FF80000, 0.0
        ),
    ],
)
def test_out_of_range_parameters_are_denied(client, endpoint, vehicle, msg):
    """Every parameter outside its MAVLink/PX4 range is DENIED before the vehicle is called."""
    assert _command(client, endpoint, msg).result == DENIED
    assert vehicle.calls == []
    assert endpoint.stats.encode_errors == 0


@pytest.mark.parametrize(
    ("msg", "call"),
    [
        (_long_at(mavlink2.MAV_CMD_DO_SET_HOME, -90, 180, -400, 0), ("set_home", False, -90, 180)),
        (_long_at(mavlink2.MAV_CMD_DO_SET_HOME, 90, -180, 9000, 0), ("set_home", False, 90, -180)),
        (command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 0, 3, -1, 0), ("change_speed", 3)),
        (command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 3, -2, -2, 0), ("change_speed", -2)),
        (command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 5, 50), ("change_speed", 5)),
        (command_long(mavlink2.MAV_CMD_DO_SET_MODE, 1.2, 3.9, 0.4), ("set_mode", 4, 0)),
        (command_long(mavlink2.MAV_CMD_DO_SET_MODE, 129, 4, 9), ("set_mode", 4, 9)),
        (command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0.6, 21195.7), ("arm", True)),
        (_long_at(mavlink2.MAV_CMD_NAV_LAND, 47.4, 8.5, 0), ("land",)),
        (_long_at(mavlink2.MAV_CMD_NAV_TAKEOFF, 47.4, 8.5, math.nan, 0, 0, 0, 1.0), ("takeoff",)),
        (command_long(mavlink2.MAV_CMD_DO_FLIGHTTERMINATION, 0.51), ("terminate",)),
    ],
)
def test_parameters_at_the_edge_of_their_range_are_accepted(client, endpoint, vehicle, msg, call):
    """Bounds are inclusive; rounding follows PX4 (lroundf); speed type 3 is applied like 1."""
    assert _command(client, endpoint, msg).result == ACCEPTED
    assert vehicle.calls[0][: len(call)] == call


def test_reboot_is_denied_while_armed(client, endpoint, vehicle):
    """PX4 refuses to reboot or shut down an armed vehicle; action 0 is always accepted."""
    vehicle.snapshot = replace(vehicle.snapshot, armed=True)
    reboot = command_long(mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1)
    assert _command(client, endpoint, reboot).result == DENIED
    nothing = command_long(mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0)
    assert _command(client, endpoint, nothing).result == ACCEPTED


def test_message_interval_commands_deny_ids_above_uint16_without_encode_errors(client, endpoint):
    """GET_MESSAGE_INTERVAL 0x10000 used to ACK and then fail packing MESSAGE_INTERVAL."""
    for msg_id in (0x10000, 0xFFFFFF):
        ack = _command(
            client, endpoint, command_long(mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL, msg_id)
        )
        assert ack.result == DENIED
    client.send(endpoint, command_long(mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL, 0xFFFF))
    inbox = client.exchange(endpoint, 0.0, has("MESSAGE_INTERVAL"))
    interval = next(m for m in inbox if m.get_type() == "MESSAGE_INTERVAL")
    assert (interval.message_id, interval.interval_us) == (0xFFFF, 0)
    assert endpoint.stats.encode_errors == 0
    assert endpoint.stats.handler_errors == 0


def test_command_for_an_absent_component_gets_no_ack_as_px4(client, endpoint, vehicle):
    """A command for component 100 (a camera nobody connected) stays unanswered, as in PX4.

    PX4's mavlink_receiver.cpp logs "Ignore command" and sends nothing (PR #23870); the ACK
    of the later command proves the earlier ones were processed.
    """
    for command in (mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, mavlink2.MAV_CMD_REQUEST_MESSAGE):
        client.send(endpoint, command_long(command, 1, target_component=100))
        client.send(endpoint, command_long(command, 1, target_system=0, target_component=100))
    client.send(endpoint, command_long(31000, target_component=0))
    acks = _acks(client.exchange(endpoint, 0.0, has("COMMAND_ACK")))
    assert [a.command for a in acks] == [31000]
    assert vehicle.calls == []
    assert endpoint.stats.commands_ignored == 4


@pytest.mark.parametrize("target", [(1, 100), (0, 100), (1, 1), (0, 0)])
def test_autopilot_capabilities_request_is_answered_for_any_component(client, endpoint, target):
    """PX4's evaluate_target_ok ignores the component of REQUEST_AUTOPILOT_CAPABILITIES."""
    msg = command_long(
        mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
        1,
        target_system=target[0],
        target_component=target[1],
    )
    client.send(endpoint, msg)
    inbox = client.exchange(endpoint, 0.0, has("AUTOPILOT_VERSION"))
    assert _acks(inbox)[0].result == ACCEPTED


def test_capabilities_request_for_another_system_is_ignored(client, endpoint):
    msg = command_long(mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, target_system=2)
    client.send(endpoint, msg)
    client.send(endpoint, command_long(31000))
    inbox = client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
    assert [a.command for a in _acks(inbox)] == [31000]
    assert "AUTOPILOT_VERSION" not in {m.get_type() for m in inbox}


@pytest.mark.parametrize(("param1", "expected"), [(0.0, 0), (3.0, 3), (-1.0, -1), (math.nan, -1)])
def test_mission_start_passes_the_first_item(client, endpoint, vehicle, param1, expected):
    ack = _command(client, endpoint, command_long(mavlink2.MAV_CMD_MISSION_START, param1, 0))
    assert ack.result == ACCEPTED
    assert vehicle.calls == [("start_mission", expected)]


@pytest.mark.parametrize("param1", [-2.0, 1.5, math.inf])
def test_mission_start_with_a_bad_first_item_is_denied(client, endpoint, vehicle, param1):
    ack = _command(client, endpoint, command_long(mavlink2.MAV_CMD_MISSION_START, param1, 0))
    assert ack.result == DENIED
    assert vehicle.calls == []
