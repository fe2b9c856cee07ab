"""The simulator's side of PX4's TCP simulator protocol, against raw pymavlink peers.

A peer here is a plain TCP socket with pymavlink's codec: what PX4's simulator_mavlink sends
(HEARTBEAT, SET_MESSAGE_INTERVAL, HIL_ACTUATOR_CONTROLS with or without the lockstep flag), and
what a broken one does (garbage, silence, a second connection, hanging up).
"""

from __future__ import annotations

import socket
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from sitl.hil_server import HilPortInUseError, HilServer, HilServerConfig
from sitl.world import World, WorldConfig

pytestmark = pytest.mark.sockets


class _Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class _Peer:
    """A raw autopilot: a TCP client speaking MAVLink 2 with pymavlink."""

    def __init__(self, port: int, greet: bool = True) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5.0)
        self.mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True
        self.inbox: list = []
        if greet:  # PX4's first message
            self.send(mavlink2.MAVLink_heartbeat_message(0, 12, 0, 0, 0, 3))

    def send(self, msg) -> None:
        self.sock.sendall(msg.pack(self.mav))

    def actuators(self, value: float, lockstep: bool = True, armed: bool = True) -> None:
        mode = mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            mavlink2.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0
        )
        self.send(
            mavlink2.MAVLink_hil_actuator_controls_message(0, [value] * 16, mode, int(lockstep))
        )

    def read(self, seconds: float = 0.3) -> list:
        self.sock.settimeout(0.05)
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            if not data:
                break
            self.inbox += [m for m in self.mav.parse_buffer(data) or []]
        return self.inbox

    def of(self, kind: str) -> list:
        return [m for m in self.inbox if m.get_type() == kind]

    def closed_by_server(self) -> bool:
        """The server hung up: an orderly close, or a reset (it closed with our data unread)."""
        self.sock.settimeout(2.0)
        try:
            while data := self.sock.recv(65536):
                self.mav.parse_buffer(data)
        except ConnectionResetError:
            return True
        except TimeoutError:
            return False
        return True

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def world():
    with World(WorldConfig(n_vehicles=2, seed=3)) as w:
        yield w


def _server(n: int = 2, **changes) -> tuple[HilServer, _Clock]:
    clock = _Clock()
    return HilServer(HilServerConfig(n_vehicles=n, port_base=0, **changes), clock), clock


def _sensor_messages(world: World) -> list:
    while True:
        world.step()
        sensors, _ = world.poll_sensors()
        if sensors is not None:
            return sensors


def _connect_all(server: HilServer) -> list[_Peer]:
    peers = [_Peer(p) for p in server.ports()]
    assert server.wait_for_autopilots(timeout_s=5.0)
    return peers


def test_a_taken_port_is_a_clear_error():
    """A second simulator on a vehicle's port: refused at start, naming port and vehicle."""
    first, _ = _server(1)
    try:
        taken = first.ports()[0]
        with pytest.raises(HilPortInUseError, match=rf"127\.0\.0\.1:{taken} .*vehicle 1"):
            HilServer(HilServerConfig(n_vehicles=1, port_base=taken), _Clock())
    finally:
        first.close()


def test_sensors_reach_each_vehicle_and_lockstep_replies_come_back(world):
    server, _ = _server()
    peers = _connect_all(server)
    try:
        sensors = _sensor_messages(world)
        server.send_sensors(sensors)
        assert server.actuators() is None  # no peer flagged lockstep yet: nothing waits
        for i, p in enumerate(peers):
            got = p.read()
            (msg,) = [m for m in got if m.get_type() == "HIL_SENSOR"]
            assert msg.time_usec == sensors[i].time_usec
            assert msg.xacc == sensors[i].xacc  # float32 in memory, float32 on the wire
            p.actuators(0.1 * (i + 1))
        deadline = time.monotonic() + 5
        while min(st.actuator_messages for st in server.stats()) < 1:
            assert time.monotonic() < deadline
            server.actuators()
        # Both flagged lockstep: the next HIL_SENSOR makes actuators() wait for both replies.
        server.send_sensors(_sensor_messages(world))
        for i, p in enumerate(peers):
            p.read(0.2)
            p.actuators(0.5 + i)
        replies = server.actuators()
        assert replies is not None
        assert [r.controls[0] for r in replies] == pytest.approx([0.5, 1.5])
    finally:
        for p in peers:
            p.close()
        server.close()


def test_a_second_autopilot_is_refused_and_the_first_keeps_flying(world):
    server, _ = _server(1)
    first = _Peer(server.ports()[0])
    try:
        assert server.wait_for_autopilots(timeout_s=5.0)
        intruder = _Peer(server.ports()[0])
        deadline = time.monotonic() + 5
        while server.stats()[0].refused == 0 and time.monotonic() < deadline:
            server.actuators()
        assert intruder.closed_by_server()
        assert server.connected == [True]
        server.send_sensors(_sensor_messages(world)[:1])
        server.actuators()
        assert first.read() and first.of("HIL_SENSOR")
    finally:
        first.close()
        server.close()


def test_garbage_is_counted_and_a_valid_frame_after_it_still_works(world):
    server, _ = _server(1)
    (peer,) = _connect_all(server)
    try:
        peer.sock.sendall(b"GET / HTTP/1.1\r\n\r\n" + bytes(range(256)) * 4)
        # The parser resynchronises on the byte stream: a frame right behind garbage may be
        # swallowed by a false frame start (as in PX4's parser); the next one parses.
        peer.actuators(0.3, lockstep=False)
        peer.actuators(0.3, lockstep=False)
        deadline = time.monotonic() + 5
        out = None
        while out is None and time.monotonic() < deadline:
            out = server.actuators()
        assert out is not None and out[0].controls[0] == pytest.approx(0.3)
        assert server.stats()[0].bad_frames > 0
        assert server.connected == [True]
    finally:
        peer.close()
        server.close()


def test_a_disconnect_stops_the_motors_and_a_new_autopilot_takes_over(world, caplog):
    server, _ = _server(1)
    (peer,) = _connect_all(server)
    try:
        peer.actuators(0.6)
        while server.actuators() is None:
            pass
        peer.close()
        deadline = time.monotonic() + 5
        out = None
        while out is None and time.monotonic() < deadline:
            out = server.actuators()
        assert out is not None
        assert out[0].mode & mavlink2.MAV_MODE_FLAG_SAFETY_ARMED == 0  # disarmed: motors stop
        assert max(out[0].controls) == 0.0
        assert server.stats()[0].disconnects == 1
        assert "disconnected" in caplog.text and "motors stop" in caplog.text
        # The simulation goes on (no autopilot: nothing waits) ...
        server.send_sensors(_sensor_messages(world)[:1])
        assert server.actuators() is None
        # ... and a restarted autopilot takes the vehicle back.
        again = _Peer(server.ports()[0])
        assert server.wait_for_autopilots(timeout_s=5.0)
        again.actuators(0.4)
        deadline = time.monotonic() + 5
        out = None
        while out is None and time.monotonic() < deadline:
            out = server.actuators()
        assert out is not None and out[0].controls[0] == pytest.approx(0.4)
        again.close()
    finally:
        server.close()


def test_a_silent_lockstep_autopilot_is_dropped_not_waited_for_forever(world, caplog):
    server, _ = _server(1, stall_timeout_s=0.3)
    (peer,) = _connect_all(server)
    try:
        peer.actuators(0.5)  # lockstep flagged: the next HIL_SENSOR will be waited for
        while server.actuators() is None:
            pass
        server.send_sensors(_sensor_messages(world)[:1])
        out = server.actuators()  # the peer never answers
        assert out is not None and max(out[0].controls) == 0.0
        assert server.stats()[0].stalls == 1 and server.connected == [False]
        assert "lockstep" in caplog.text
    finally:
        peer.close()
        server.close()


def test_an_autopilot_without_lockstep_is_dropped_after_a_second_of_simulated_silence(world):
    server, clock = _server(1, actuator_timeout_s=1.0)
    (peer,) = _connect_all(server)
    try:
        peer.actuators(0.5, lockstep=False)
        while server.actuators() is None:
            pass
        clock.t = 0.9
        assert server.actuators() is None and server.connected == [True]
        clock.t = 1.1
        out = server.actuators()
        assert out is not None and max(out[0].controls) == 0.0
        assert server.stats()[0].stalls == 1
    finally:
        peer.close()
        server.close()


def test_ground_truth_at_the_interval_the_autopilot_asks_for(world):
    """PX4 asks for HIL_STATE_QUATERNION every 5 ms; it comes with a COMMAND_ACK."""
    server, clock = _server(2)
    peers = _connect_all(server)
    try:
        peers[0].send(
            mavlink2.MAVLink_command_long_message(
                0, 0, mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 115, 5000, 0, 0, 0, 0, 0
            )
        )
        time.sleep(0.2)
        server.actuators()
        for k in range(100):  # 0.2 s of 500 Hz steps
            clock.t = k * 0.002
            world.step()
            server.send_state(clock.t, lambda: world.truth)
            server.actuators()
        got = peers[0].read()
        states = peers[0].of("HIL_STATE_QUATERNION")
        assert [(a.command, a.result) for a in peers[0].of("COMMAND_ACK")] == [
            (mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink2.MAV_RESULT_ACCEPTED)
        ]
        assert len(states) == 40  # every 5 ms over 0.2 s
        truth = world.truth
        assert states[-1].alt == round(float(truth.alt_amsl_m[0]) * 1000)
        assert np.allclose(
            states[-1].attitude_quaternion, truth.quaternion_ned_frd_wxyz[0], atol=1e-6
        )
        assert len([m for m in got if m.get_type() == "HEARTBEAT"]) >= 1
        assert not peers[1].read(0.1) or not peers[1].of("HIL_STATE_QUATERNION")  # not asked
    finally:
        for p in peers:
            p.close()
        server.close()


def test_hil_data_waits_for_the_autopilots_heartbeat(world):
    """PX4 greets with a HEARTBEAT first; before it, the connection gets no sensor data."""
    server, _ = _server(1)
    peer = _Peer(server.ports()[0], greet=False)
    try:
        assert not server.wait_for_autopilots(timeout_s=0.5)
        assert server.connected == [True] and server.greeted == [False]
        server.send_sensors(_sensor_messages(world)[:1])
        server.actuators()
        peer.read()
        assert not peer.of("HIL_SENSOR")
        peer.send(mavlink2.MAVLink_heartbeat_message(0, 12, 0, 0, 0, 3))
        assert server.wait_for_autopilots(timeout_s=5.0)
        server.send_sensors(_sensor_messages(world)[:1])
        server.actuators()
        peer.read()
        assert len(peer.of("HIL_SENSOR")) == 1
    finally:
        peer.close()
        server.close()
