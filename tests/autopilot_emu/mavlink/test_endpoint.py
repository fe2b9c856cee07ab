"""MavlinkEndpoint over real loopback UDP: identity, streams, robustness, tlog, socket errors."""

from __future__ import annotations

import math
import socket
from dataclasses import replace

import numpy as np
import pytest
from mavlink_fakes import (
    EPOCH_START_S,
    MavClient,
    command_long,
    has,
    make_endpoint,
)
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint import (
    HELD_HEARTBEAT_WALL_S,
    EndpointConfig,
    MavlinkEndpoint,
    PortInUseError,
)
from autopilot_emu.mavlink.streams import (
    MAX_STREAM_RATE_HZ,
    MIN_INTERVAL_US,
    PROFILES,
    StreamProfile,
    StreamScheduler,
    profile_streams,
    rate_to_interval_us,
)

pytestmark = pytest.mark.sockets

ONBOARD = PROFILES[StreamProfile.ONBOARD]
ATTITUDE_HZ = ONBOARD["ATTITUDE"]
"""Default ATTITUDE rate of the endpoints under test (the onboard profile)."""


def _drive(endpoint, client, start_ms, stop_ms):
    """Poll every simulated millisecond in (start_ms, stop_ms]; return the messages received."""
    received = []
    for ms in range(start_ms + 1, stop_ms + 1):
        endpoint.poll(ms / 1000.0)
        if ms % 50 == 0:
            received += client.drain()
    received += client.drain()
    return received


def _count(messages, type_name):
    return sum(m.get_type() == type_name for m in messages)


def test_heartbeat_identifies_a_px4_hexarotor_with_mode_and_armed_flag(client, vehicle):
    """HEARTBEAT: PX4 autopilot, hexarotor, custom mode (main<<16 | sub<<24), armed bit."""
    vehicle.snapshot = replace(vehicle.snapshot, armed=True, main_mode=4, sub_mode=3)
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("HEARTBEAT"))
    heartbeat = next(m for m in inbox if m.get_type() == "HEARTBEAT")
    assert heartbeat.get_srcSystem() == 1
    assert heartbeat.get_srcComponent() == 1
    assert heartbeat.type == mavlink2.MAV_TYPE_HEXAROTOR
    assert heartbeat.autopilot == mavlink2.MAV_AUTOPILOT_PX4
    assert heartbeat.custom_mode == 0x03040000
    assert heartbeat.base_mode & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert heartbeat.base_mode & mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    assert heartbeat.base_mode & mavlink2.MAV_MODE_FLAG_AUTO_ENABLED
    assert heartbeat.system_status == vehicle.snapshot.system_status
    assert heartbeat.get_msgbuf()[0] == mavlink2.PROTOCOL_MARKER_V2


def test_heartbeat_type_follows_the_mav_type_parameter(client, vehicle):
    """A quad airframe (MAV_TYPE 2) reports itself as a quadrotor."""
    vehicle.params.set("MAV_TYPE", mavlink2.MAV_TYPE_QUADROTOR)
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("HEARTBEAT"))
    heartbeat = next(m for m in inbox if m.get_type() == "HEARTBEAT")
    assert heartbeat.type == mavlink2.MAV_TYPE_QUADROTOR


def test_disarmed_offboard_heartbeat(client, vehicle):
    vehicle.snapshot = replace(vehicle.snapshot, armed=False, main_mode=6, sub_mode=0)
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("HEARTBEAT"))
    heartbeat = next(m for m in inbox if m.get_type() == "HEARTBEAT")
    assert heartbeat.custom_mode == 393216
    assert not heartbeat.base_mode & mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    assert heartbeat.base_mode & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED


@pytest.mark.parametrize("profile", list(StreamProfile))
def test_default_stream_rates_in_simulation_time(client, vehicle, profile):
    """Over 2 s of simulated time every stream of the profile goes out at its default rate, one
    message per interval, and no other stream goes out."""
    with make_endpoint(vehicle, peers=(client.address,), profile=profile) as endpoint:
        endpoint.poll(0.0)
        client.drain()
        received = _drive(endpoint, client, 0, 2000)
    for spec in profile_streams(profile, unlimited_rate_hz=10.0):
        expected = 0
        if spec.default_rate_hz > 0:
            expected = 2_000_000 // rate_to_interval_us(spec.default_rate_hz)
        assert _count(received, spec.name) == expected, spec.name


def test_set_message_interval_changes_stops_and_restores_a_stream(client, vehicle):
    """SET_MESSAGE_INTERVAL: >0 sets the interval, -1 stops, 0 restores the default."""
    with make_endpoint(vehicle) as endpoint:
        client.send(endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 100_000))
        inbox = client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
        ack = next(m for m in inbox if m.get_type() == "COMMAND_ACK")
        assert (ack.command, ack.result) == (mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 0)
        assert _count(_drive(endpoint, client, 0, 2000), "ATTITUDE") == 20

        client.send(endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 30, -1))
        client.exchange(endpoint, 2.0, has("COMMAND_ACK"))
        received = _drive(endpoint, client, 2000, 4000)
        assert _count(received, "ATTITUDE") == 0
        assert _count(received, "ATTITUDE_QUATERNION") == 2 * ONBOARD["ATTITUDE_QUATERNION"]

        client.send(endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 30, 0))
        client.exchange(endpoint, 4.0, has("COMMAND_ACK"))
        assert _count(_drive(endpoint, client, 4000, 6000), "ATTITUDE") == 2 * ATTITUDE_HZ


def test_set_message_interval_for_unknown_message_is_denied(client, vehicle):
    with make_endpoint(vehicle) as endpoint:
        client.send(endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 1000))
        inbox = client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
    assert next(m for m in inbox if m.get_type() == "COMMAND_ACK").result == 2


def test_flight_information_streams_only_when_asked_for(client, vehicle):
    """FLIGHT_INFORMATION is off by default and streams at the rate SET_MESSAGE_INTERVAL asks.

    MAVSDK's ``info.flight_information()`` subscription asks for it at 1 Hz and gets nothing
    else (found by tests/conformance).
    """
    msg_id = mavlink2.MAVLINK_MSG_ID_FLIGHT_INFORMATION
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        client.drain()
        assert _count(_drive(endpoint, client, 0, 2000), "FLIGHT_INFORMATION") == 0
        client.send(endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6))
        inbox = client.exchange(endpoint, 2.0, has("COMMAND_ACK"))
        assert next(m for m in inbox if m.get_type() == "COMMAND_ACK").result == 0
        assert _count(_drive(endpoint, client, 2000, 5000), "FLIGHT_INFORMATION") == 3


def test_stream_rate_overrides_from_config(client, vehicle):
    with make_endpoint(
        vehicle, peers=(client.address,), stream_rates_hz={"ATTITUDE": 50.0, "VFR_HUD": 0}
    ) as endpoint:
        endpoint.poll(0.0)
        client.drain()
        received = _drive(endpoint, client, 0, 1000)
    assert _count(received, "ATTITUDE") == 50
    assert _count(received, "VFR_HUD") == 0


def test_unknown_stream_name_in_config_is_rejected(vehicle):
    with pytest.raises(ValueError, match="ATTITUDES"):
        make_endpoint(vehicle, stream_rates_hz={"ATTITUDES": 5.0})


def test_telemetry_is_read_at_most_once_per_poll_and_only_when_due(client, vehicle):
    """One snapshot per poll at which a stream is due (MISSION_CURRENT alone needs none)."""
    due_polls = 0
    scheduler = StreamScheduler(profile_streams(StreamProfile.ONBOARD, 10.0))
    scheduler.pop_due(0)
    for ms in range(1, 1001):
        names = {spec.name for spec in scheduler.pop_due(ms * 1000)}
        due_polls += bool(names - {"MISSION_CURRENT"})
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        assert vehicle.telemetry_calls == 1
        endpoint.poll(0.0001)
        assert vehicle.telemetry_calls == 1
        for ms in range(1, 1001):
            endpoint.poll(ms / 1000.0)
        assert vehicle.telemetry_calls == 1 + due_polls


def test_home_position_is_not_streamed_without_a_home(client, vehicle):
    vehicle.snapshot = replace(vehicle.snapshot, home=None)
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        received = client.drain() + _drive(endpoint, client, 0, 4000)
    assert _count(received, "HOME_POSITION") == 0
    assert _count(received, "HEARTBEAT") == 5


def test_nan_position_suppresses_position_messages(client, vehicle):
    """Before the estimator has a position nothing invalid goes out, and nothing crashes."""
    vehicle.snapshot = replace(
        vehicle.snapshot,
        lat_deg=math.nan,
        lon_deg=math.nan,
        position_ned_m=(math.nan, math.nan, math.nan),
        euler_rad=(0.0, 0.0, math.nan),
        battery_voltage_v=math.nan,
        gps_fix_type=0,
        gps_lat_deg=math.nan,
        gps_lon_deg=math.nan,
        gps_satellites=0,
    )
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("HEARTBEAT"))
        assert endpoint.stats.encode_errors == 0
    types = {m.get_type() for m in inbox}
    assert "GLOBAL_POSITION_INT" not in types
    assert "LOCAL_POSITION_NED" not in types
    assert {"GPS_RAW_INT", "SYS_STATUS", "ATTITUDE", "VFR_HUD"} <= types


def test_status_texts_are_forwarded_and_long_ones_chunked(client, vehicle):
    long_text = "Takeoff detected, climbing to the mission altitude of 25 m above home"
    vehicle.status_texts = [(6, "Armed by external command"), (4, long_text)]
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        inbox = client.exchange(endpoint, 0.0, has("STATUSTEXT", 3))
    texts = [m for m in inbox if m.get_type() == "STATUSTEXT"]
    assert (texts[0].severity, texts[0].text, texts[0].id) == (6, "Armed by external command", 0)
    chunks = texts[1:]
    assert len({c.id for c in chunks}) == 1 and chunks[0].id != 0
    assert [c.chunk_seq for c in chunks] == [0, 1]
    assert "".join(c.text for c in chunks) == long_text


def test_ping_request_is_answered_to_the_sender(client, vehicle):
    with make_endpoint(vehicle) as endpoint:
        client.send(endpoint, mavlink2.MAVLink_ping_message(123456, 7, 0, 0))
        inbox = client.exchange(endpoint, 0.0, has("PING"))
    ping = next(m for m in inbox if m.get_type() == "PING")
    assert (ping.time_usec, ping.seq, ping.target_system, ping.target_component) == (
        123456,
        7,
        245,
        190,
    )


def test_ping_stream_carries_simulation_time_and_notes_the_peers_echo(client, vehicle):
    """With ping_period_s, PING requests (target 0/0) go out at that period in simulated time
    with time_usec = the simulation time; an echo addressed to us is noted in ``presence``
    (simulation and wall time), never answered; an echo of a time not yet sent is ignored."""
    wall = [100.0]
    with make_endpoint(
        vehicle, peers=(client.address,), wall_clock_s=lambda: wall[0], ping_period_s=0.05
    ) as endpoint:
        endpoint.poll(0.0)
        client.drain()
        pings = [m for m in _drive(endpoint, client, 0, 1000) if m.get_type() == "PING"]
        assert [p.time_usec for p in pings] == [50_000 * k for k in range(1, 21)]
        assert {(p.target_system, p.target_component) for p in pings} == {(0, 0)}
        assert endpoint.presence.echo_s == -math.inf
        echo = pings[9]  # t = 0.5 s
        wall[0] = 101.5
        reply = mavlink2.MAVLink_ping_message(echo.time_usec, echo.seq, 1, 1)
        client.send(endpoint, reply)
        inbox = client.exchange(endpoint, 1.0, lambda _: endpoint.presence.echo_s > 0)
        assert endpoint.presence.echo_s == 0.5 and endpoint.presence.echo_wall_s == 101.5
        assert not [m for m in inbox if m.get_type() == "PING" and m.target_system == 245]
        received = endpoint.stats.frames_received
        client.send(endpoint, mavlink2.MAVLink_ping_message(5_000_000, 1, 1, 1))  # not sent yet
        client.exchange(endpoint, 1.0, lambda _: endpoint.stats.frames_received > received)
        assert endpoint.presence.echo_s == 0.5


def test_without_a_ping_period_no_ping_goes_out(client, vehicle):
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        assert not [m for m in _drive(endpoint, client, 0, 1000) if m.get_type() == "PING"]


def test_a_ground_stations_heartbeat_is_noted_with_its_times(client, vehicle):
    """GCS HEARTBEATs (the kind PX4's data-link check counts) are noted; others are not."""
    with make_endpoint(vehicle, wall_clock_s=lambda: 7.0) as endpoint:
        onboard = mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
        )
        client.send(endpoint, onboard)
        client.exchange(endpoint, 2.0, lambda _: endpoint.stats.frames_received >= 1)
        assert endpoint.presence.heartbeat_s == -math.inf
        gcs = mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_GCS, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
        )
        client.send(endpoint, gcs)
        client.exchange(endpoint, 3.0, lambda _: endpoint.stats.frames_received >= 2)
        assert (endpoint.presence.heartbeat_s, endpoint.presence.heartbeat_wall_s) == (3.0, 7.0)


def test_a_held_link_still_sends_heartbeat_once_a_wall_second(client, vehicle):
    """keep_alive (a held lockstep calls it): a HEARTBEAT when the link sent none, streamed
    ones included, for HELD_HEARTBEAT_WALL_S wall seconds; never on a link whose HEARTBEAT
    stream is off."""
    wall = [100.0]
    with make_endpoint(vehicle, peers=(client.address,), wall_clock_s=lambda: wall[0]) as endpoint:
        endpoint.poll(0.0)  # the stream's HEARTBEAT of t = 0, at wall 100 s
        assert _count(client.drain(), "HEARTBEAT") == 1
        wall[0] = 100.0 + HELD_HEARTBEAT_WALL_S - 0.01
        endpoint.keep_alive()
        assert _count(client.drain(), "HEARTBEAT") == 0
        wall[0] = 100.0 + HELD_HEARTBEAT_WALL_S
        endpoint.keep_alive()
        endpoint.keep_alive()
        assert _count(client.drain(), "HEARTBEAT") == 1
        wall[0] += 0.5
        endpoint.poll(1.0)  # the stream's HEARTBEAT of t = 1 s
        assert _count(client.drain(), "HEARTBEAT") == 1
        wall[0] += HELD_HEARTBEAT_WALL_S - 0.01
        endpoint.keep_alive()
        assert _count(client.drain(), "HEARTBEAT") == 0
        wall[0] += 0.01
        endpoint.keep_alive()
        assert _count(client.drain(), "HEARTBEAT") == 1
    with make_endpoint(
        vehicle,
        peers=(client.address,),
        wall_clock_s=lambda: wall[0],
        stream_rates_hz={"HEARTBEAT": 0},
    ) as quiet:
        quiet.poll(0.0)
        wall[0] += 10 * HELD_HEARTBEAT_WALL_S
        quiet.keep_alive()
        assert _count(client.drain(), "HEARTBEAT") == 0


def test_learned_peer_receives_streams_and_configured_peers_are_kept(client, vehicle):
    """The sender of valid MAVLink becomes a peer; configured peers stay first."""
    other = MavClient()
    try:
        with make_endpoint(vehicle, peers=(other.address,)) as endpoint:
            endpoint.poll(0.0)
            assert client.drain() == []
            client.send(endpoint, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
            client.exchange(endpoint, 0.5, lambda inbox: True)
            _drive(endpoint, client, 500, 1000)
            assert _count(client.inbox, "HEARTBEAT") >= 1
            assert _count(other.drain(), "HEARTBEAT") >= 2
            assert endpoint.peers == (other.address, client.address)
    finally:
        other.close()


def test_malformed_input_is_counted_and_the_endpoint_keeps_working(client, vehicle):
    """Garbage, a bad CRC and a truncated frame are counted, never raised."""
    rng = np.random.default_rng(7)
    good = command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 148).pack(client.mav)
    corrupted = bytearray(good)
    corrupted[-1] ^= 0xFF
    with make_endpoint(vehicle) as endpoint:
        client.send_raw(endpoint, rng.integers(0, 256, 200, dtype=np.uint8).tobytes())
        client.send_raw(endpoint, bytes(corrupted))
        client.send_raw(endpoint, good[:20])
        client.send_raw(endpoint, b"\xfd")
        client.send_raw(endpoint, b"")
        for _ in range(3):
            endpoint.poll(0.0)
        assert endpoint.stats.parse_errors >= 4
        assert endpoint.stats.handler_errors == 0
        assert endpoint.stats.datagrams_received == 5
        client.send(endpoint, command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 148))
        inbox = client.exchange(endpoint, 0.01, has("AUTOPILOT_VERSION"))
    assert next(m for m in inbox if m.get_type() == "COMMAND_ACK").result == 0


def test_frames_of_another_dialect_are_counted_as_unknown(client, vehicle):
    from pymavlink.dialects.v20 import ardupilotmega

    foreign = ardupilotmega.MAVLink(None, 245, 190)
    frame = ardupilotmega.MAVLink_ahrs_message(0, 0, 0, 0, 0, 0, 0).pack(foreign)
    with make_endpoint(vehicle) as endpoint:
        client.send_raw(endpoint, frame)
        client.send(endpoint, mavlink2.MAVLink_ping_message(1, 1, 0, 0))
        client.exchange(endpoint, 0.0, has("PING"))
        assert endpoint.stats.unknown_messages == 1
        assert endpoint.stats.parse_errors == 0


def test_tlog_holds_both_directions_and_simulation_timestamps(tmp_path, client, vehicle):
    """The .tlog is readable by pymavlink and stamps frames with epoch + simulation time."""
    path = tmp_path / "run" / "vehicle1.tlog"
    with make_endpoint(vehicle, tlog_path=path) as endpoint:
        endpoint.poll(0.0)
        assert not path.exists() or path.stat().st_size >= 0
        client.send(
            endpoint,
            mavlink2.MAVLink_param_request_read_message(1, 1, b"MIS_TAKEOFF_ALT", -1),
        )
        client.exchange(endpoint, 1.5, has("PARAM_VALUE"))
        sent = endpoint.stats.frames_sent
    log = mavutil.mavlink_connection(str(path))
    records = []
    while (msg := log.recv_msg()) is not None:
        records.append((msg.get_type(), msg.get_srcSystem(), msg._timestamp))
    log.close()
    assert ("PARAM_REQUEST_READ", 245, pytest.approx(EPOCH_START_S + 1.5)) in records
    assert ("PARAM_VALUE", 1, pytest.approx(EPOCH_START_S + 1.5)) in records
    assert ("HEARTBEAT", 1, pytest.approx(EPOCH_START_S)) in records
    assert sum(src == 1 for _, src, _ in records) == sent


def test_tlog_is_not_created_when_nothing_is_logged(tmp_path, vehicle):
    path = tmp_path / "never.tlog"
    endpoint = make_endpoint(vehicle, tlog_path=path)
    endpoint.close()
    assert not path.exists()


def test_busy_port_raises_port_in_use_error(vehicle):
    blocker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    blocker.bind(("127.0.0.1", 0))
    port = blocker.getsockname()[1]
    try:
        with pytest.raises(PortInUseError, match=f"127.0.0.1:{port}") as info:
            MavlinkEndpoint(vehicle, EndpointConfig(listen_port=port, peers=()))
        assert isinstance(info.value, OSError)
    finally:
        blocker.close()


def test_unreachable_peer_never_breaks_sending(vehicle):
    """Frames to a port nobody listens on are dropped silently."""
    dead = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    dead.bind(("127.0.0.1", 0))
    dead_address = dead.getsockname()
    dead.close()
    with make_endpoint(vehicle, peers=(dead_address,)) as endpoint:
        for ms in range(0, 3000, 10):
            endpoint.poll(ms / 1000.0)
        assert endpoint.stats.frames_sent > 100


def test_close_is_idempotent_and_poll_after_close_fails(vehicle):
    endpoint = make_endpoint(vehicle)
    endpoint.close()
    endpoint.close()
    with pytest.raises(RuntimeError):
        endpoint.poll(0.0)


def test_time_going_backwards_restarts_the_streams(client, vehicle):
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        _drive(endpoint, client, 0, 5000)
        client.inbox.clear()
        inbox = client.exchange(endpoint, 0.0, has("HEARTBEAT"))
    assert _count(inbox, "HEARTBEAT") == 1


@pytest.mark.parametrize("kwargs", [{"sysid": 0}, {"compid": 256}, {"listen_port": 70000}])
def test_config_validation(kwargs):
    with pytest.raises(ValueError):
        EndpointConfig(**kwargs)


def _interval_ack(client, endpoint, now_s, msg_id, interval_us, *more):
    client.send(
        endpoint, command_long(mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, interval_us, *more)
    )
    inbox = client.exchange(endpoint, now_s, has("COMMAND_ACK"))
    return next(m for m in inbox if m.get_type() == "COMMAND_ACK").result


def test_set_message_interval_never_drives_a_stream_past_the_max_rate(client, vehicle):
    """1 us is accepted (as PX4) but ATTITUDE then goes out at MAX_STREAM_RATE_HZ, no faster."""
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        assert _interval_ack(client, endpoint, 0.0, 30, 1) == 0
        received = _drive(endpoint, client, 0, 1000)
        assert _count(received, "ATTITUDE") == MAX_STREAM_RATE_HZ
        client.send(endpoint, command_long(mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL, 30))
        inbox = client.exchange(endpoint, 1.0, has("MESSAGE_INTERVAL"))
    interval = next(m for m in inbox if m.get_type() == "MESSAGE_INTERVAL")
    assert interval.interval_us == MIN_INTERVAL_US


def test_heartbeat_rate_cannot_be_changed(client, vehicle):
    """PX4 refuses SET_MESSAGE_INTERVAL for HEARTBEAT: the fuzzed 250 Hz heartbeat stays 1 Hz."""
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        assert _interval_ack(client, endpoint, 0.0, 0, 1) == 2
        assert _interval_ack(client, endpoint, 0.0, 0, -1) == 2
        received = _drive(endpoint, client, 0, 3000)
    assert _count(received, "HEARTBEAT") == 3


@pytest.mark.parametrize(
    "params",
    [
        (30, 1e30),  # the fuzz finding: beyond int32 microseconds
        (30, -1e30),
        (30, 2.0**31),
        (30, math.inf),
        (30, 100_000, 1),  # req_param3: not supported by PX4
        (30, 100_000, math.nan, 2),  # req_param4
        (30, 100_000, math.nan, math.nan, math.nan, math.nan, 2),  # response target: broadcast
    ],
)
def test_unrepresentable_or_unsupported_intervals_are_denied(client, vehicle, params):
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        assert _interval_ack(client, endpoint, 0.0, *params) == 2
        assert _count(_drive(endpoint, client, 0, 1000), "ATTITUDE") == ATTITUDE_HZ  # unchanged


def test_any_negative_interval_stops_a_stream_and_tiny_ones_restore_the_default(client, vehicle):
    """PX4: interval < -1e-5 us stops the stream, |interval| <= 1e-5 us means the default."""
    with make_endpoint(vehicle, peers=(client.address,)) as endpoint:
        endpoint.poll(0.0)
        assert _interval_ack(client, endpoint, 0.0, 30, -5) == 0
        assert _count(_drive(endpoint, client, 0, 1000), "ATTITUDE") == 0
        assert _interval_ack(client, endpoint, 1.0, 30, 1e-6) == 0
        assert _count(_drive(endpoint, client, 1000, 2000), "ATTITUDE") == ATTITUDE_HZ
        assert _interval_ack(client, endpoint, 2.0, 30, 0.6) == 0  # rounds to 1 us: fastest
        assert _count(_drive(endpoint, client, 2000, 3000), "ATTITUDE") == MAX_STREAM_RATE_HZ


def test_tlog_holds_only_valid_frames_of_known_messages(tmp_path, client, vehicle):
    """Unknown message ids, bad CRCs, garbage and truncated frames never reach the .tlog."""
    from pymavlink.dialects.v20 import ardupilotmega

    path = tmp_path / "vehicle1.tlog"
    foreign = ardupilotmega.MAVLink(None, 245, 190)
    unknown = ardupilotmega.MAVLink_ahrs_message(0, 0, 0, 0, 0, 0, 0).pack(foreign)
    good = command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, 148).pack(client.mav)
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    with make_endpoint(vehicle, tlog_path=path, stream_rates_hz={"HEARTBEAT": 0}) as endpoint:
        for junk in (unknown, bytes(bad_crc), good[:15], b"\xfd\x09\x00" + bytes(30), unknown):
            client.send_raw(endpoint, junk)
        client.send(endpoint, mavlink2.MAVLink_ping_message(1, 1, 0, 0))
        client.exchange(endpoint, 0.0, has("PING"))
        assert endpoint.stats.unknown_messages == 2
        received, sent = endpoint.stats.frames_received, endpoint.stats.frames_sent
    log = mavutil.mavlink_connection(str(path), dialect="common")
    types = []
    while (msg := log.recv_msg()) is not None:
        types.append(msg.get_type())
        assert msg.get_type() != "BAD_DATA"
        assert msg.get_msgId() in mavlink2.mavlink_map  # not UNKNOWN_*: a known, CRC-checked id
    log.close()
    assert "PING" in types
    assert len(types) == sent + (received - endpoint.stats.unknown_messages)
