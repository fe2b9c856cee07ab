"""The serial port (a pseudo-terminal) as a MAVLink link: stream parsing, never blocking."""

from __future__ import annotations

import os
import time

import pytest
from mavlink_fakes import EPOCH_START_S, FakeVehicle, command_long
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint import EndpointConfig, MavlinkEndpoint
from autopilot_emu.mavlink.streams import STREAMABLE
from autopilot_emu.mavlink.transport import PtyTransport

QUIET = dict.fromkeys(STREAMABLE, 0.0)


def serial_endpoint(vehicle, transport, **config):
    return MavlinkEndpoint(
        vehicle,
        EndpointConfig(listen_port=0, peers=(), epoch_start_s=EPOCH_START_S, **config),
        hub=None,
        transport=transport,
    )


@pytest.fixture
def pty(tmp_path):
    transport = PtyTransport(tmp_path / "vehicle1.serial")
    yield transport
    transport.close()


def _client_fd(path) -> int:
    fd = os.open(str(path), os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    return fd


def _read_all(fd) -> bytes:
    out = b""
    while True:
        try:
            chunk = os.read(fd, 65536)
        except BlockingIOError:
            return out
        if not chunk:
            return out
        out += chunk


def test_the_symlink_points_at_the_pty_and_goes_on_close(tmp_path):
    transport = PtyTransport(tmp_path / "vehicle1.serial")
    link = tmp_path / "vehicle1.serial"
    assert link.is_symlink() and os.readlink(link) == transport.device
    assert transport.path == str(link)
    transport.close()
    transport.close()
    assert not link.exists() and not link.is_symlink()


def test_pymavlink_reads_heartbeats_and_gets_a_command_ack(pty):
    vehicle = FakeVehicle()
    with serial_endpoint(vehicle, pty) as ep:
        client = mavutil.mavlink_connection(pty.path, baud=921600, source_system=245)
        try:
            hb = None
            for k in range(200):
                ep.poll(k * 0.01)
                hb = client.recv_match(type="HEARTBEAT", blocking=False)
                if hb is not None:
                    break
                time.sleep(0.001)
            assert hb is not None and hb.get_srcSystem() == 1
            client.mav.command_long_send(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
            ack = None
            for k in range(200):
                ep.poll(2.0 + k * 0.01)
                ack = client.recv_match(type="COMMAND_ACK", blocking=False)
                if ack is not None:
                    break
                time.sleep(0.001)
            assert ack is not None and ack.command == 400
            assert ack.result == mavlink2.MAV_RESULT_ACCEPTED
            assert ("arm", False) in vehicle.calls
        finally:
            client.close()


def test_frames_split_across_reads_and_garbage_between_them(pty):
    """A byte stream: half a frame now, the rest later, garbage in between; every whole frame
    is handled and the garbage counted, as the endpoint counts malformed datagrams."""
    vehicle = FakeVehicle()
    mav = mavlink2.MAVLink(None, srcSystem=245, srcComponent=190)
    arm = command_long(400, 1).pack(mav)
    mav.seq = 1
    disarm = command_long(400, 0).pack(mav)
    with serial_endpoint(vehicle, pty, stream_rates_hz=QUIET) as ep:
        fd = _client_fd(pty.path)
        try:
            os.write(fd, arm[:7])
            ep.poll(0.0)
            assert ep.stats.commands_handled == 0
            os.write(fd, arm[7:] + b"\x00garbage\x55" + disarm[:20])
            ep.poll(0.01)
            os.write(fd, disarm[20:])
            ep.poll(0.02)
            assert ep.stats.commands_handled == 2
            assert ep.stats.parse_errors >= 1
            assert [c for c in vehicle.calls if c[0] in ("arm", "disarm")] == [
                ("arm", False),
                ("disarm", False),
            ]
            replies = mavlink2.MAVLink(None)
            replies.robust_parsing = True
            got = replies.parse_buffer(_read_all(fd)) or []
            assert [m.get_type() for m in got].count("COMMAND_ACK") == 2
        finally:
            os.close(fd)


def test_without_a_reader_frames_are_dropped_never_blocking(pty):
    """Nobody reads: the pty buffer fills, then frames are dropped and counted; a client that
    opens the port later reads whole frames only (never a cut one) and then live ones."""
    vehicle = FakeVehicle()
    rates = {name: 200.0 for name in ("ATTITUDE", "ATTITUDE_QUATERNION", "HIGHRES_IMU")}
    with serial_endpoint(vehicle, pty, stream_rates_hz=rates) as ep:
        t0 = time.monotonic()
        for k in range(3000):  # 30 simulated s, ~40 frames per poll
            ep.poll(k * 0.01)
        assert time.monotonic() - t0 < 30  # never blocked on a full buffer
        assert pty.dropped_frames > 0 and ep.stats.send_errors == pty.dropped_frames
        fd = _client_fd(pty.path)
        try:
            backlog = _read_all(fd)
            assert 0 < len(backlog) == pty.bytes_written
            parser = mavlink2.MAVLink(None)
            parser.robust_parsing = True
            frames = parser.parse_buffer(backlog) or []
            ep.poll(30.0)  # first the rest of a frame cut by a short write, if any
            live = parser.parse_buffer(_read_all(fd)) or []
            assert frames and all(m.get_type() != "BAD_DATA" for m in frames + live)
            assert any(m.get_type() == "ATTITUDE" for m in live)
        finally:
            os.close(fd)
