"""HITL over a serial port: a fake Pixhawk on the master side of a pseudo-terminal.

The simulator opens the pty's slave as it would open ``/dev/ttyACM0``; the "board" reads and
writes MAVLink 2 on the master side with pymavlink, as PX4's USB MAVLink instance does in HITL
(HEARTBEAT, HIL_ACTUATOR_CONTROLS without the lockstep flag, its telemetry); a ground station on
UDP talks to the board through the simulator's relay.
"""

from __future__ import annotations

import contextlib
import os
import select
import socket
import time

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from sitl.hil_serial import SerialPort, parse_serial
from sitl.hil_server import HilServer, HilServerConfig
from sitl.world import World, WorldConfig

pytestmark = pytest.mark.sockets


class _Board:
    """The Pixhawk: the pty's master end."""

    def __init__(self) -> None:
        self.master, slave = os.openpty()
        self.device = os.ttyname(slave)
        os.close(slave)
        self.mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True
        self.inbox: list = []

    def send(self, msg) -> None:
        os.write(self.master, msg.pack(self.mav))

    def read(self, seconds: float = 0.3) -> list:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if ready:
                self.inbox += self.mav.parse_buffer(os.read(self.master, 65536)) or []
        return self.inbox

    def of(self, kind: str) -> list:
        return [m for m in self.inbox if m.get_type() == kind]

    def close(self) -> None:
        os.close(self.master)


def _udp() -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.05)
    return sock


def _datagrams(sock: socket.socket, seconds: float = 0.3) -> list:
    parser = mavlink2.MAVLink(None)
    out = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        with contextlib.suppress(TimeoutError):
            out += parser.parse_buffer(sock.recv(65535)) or []
    return out


def _until(server: HilServer, seconds: float = 5.0):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        out = server.actuators()
        if out is not None:
            return out
    return None


def test_parse_serial():
    assert parse_serial("/dev/ttyACM0") == ("/dev/ttyACM0", 921600)
    assert parse_serial("/dev/ttyUSB1:57600") == ("/dev/ttyUSB1", 57600)
    with pytest.raises(ValueError, match="baud 1234"):
        parse_serial("/dev/ttyS0:1234")


def test_a_missing_device_is_a_clear_error():
    with pytest.raises(OSError, match="HIL serial port /dev/nonexistent-pixhawk"):
        SerialPort("/dev/nonexistent-pixhawk")
    with pytest.raises(ValueError, match="one device per vehicle"):
        HilServerConfig(n_vehicles=2, serial=("/dev/ttyACM0",))


def test_hitl_board_flies_through_the_serial_port_and_its_traffic_is_relayed():
    board = _Board()
    gcs, api = _udp(), _udp()
    server = HilServer(
        HilServerConfig(
            n_vehicles=1,
            serial=(f"{board.device}:921600",),
            relay_gcs_port=gcs.getsockname()[1],
            relay_sdk_base=api.getsockname()[1],
        ),
        lambda: 0.0,
    )
    try:
        with World(WorldConfig(n_vehicles=1, seed=2)) as world:
            assert server.connected == [True]
            assert server.describe(0) == f"serial {board.device} at 921600 baud"
            # The board: its HEARTBEAT and an armed, non-lockstep actuator command.
            board.send(mavlink2.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3))
            mode = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED | mavlink2.MAV_MODE_FLAG_HIL_ENABLED
            board.send(mavlink2.MAVLink_hil_actuator_controls_message(0, [0.4] * 16, mode, 0))
            out = _until(server)
            assert out is not None and out[0].controls[0] == pytest.approx(0.4)
            # Everything the board sent reached the ground station and the API over UDP.
            for sock in (gcs, api):
                kinds = [m.get_type() for m in _datagrams(sock)]
                assert "HEARTBEAT" in kinds and "HIL_ACTUATOR_CONTROLS" in kinds
            # The sensors go to the board; the simulation never waits for it (no lockstep).
            while (sensors := world.poll_sensors()[0]) is None:
                world.step()
            server.send_sensors(sensors)
            server.actuators()
            board.read()
            assert board.of("HIL_SENSOR")
            # A ground-station command reaches the board through the relay.
            cmd = mavlink2.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
            gcs.sendto(cmd.pack(mavlink2.MAVLink(None, 255, 190)), server.relay_address(0))
            deadline = time.monotonic() + 5
            while not board.of("COMMAND_LONG") and time.monotonic() < deadline:
                server.actuators()
                board.read(0.05)
            assert board.of("COMMAND_LONG")[0].command == 400
            # The board goes away (USB unplugged): logged, motors stop, nothing hangs.
            board.close()
            out = _until(server)
            assert out is not None and max(out[0].controls) == 0.0
            assert server.connected == [False]
    finally:
        server.close()
        gcs.close()
        api.close()
