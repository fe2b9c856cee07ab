"""The simulator's end of PX4's simulator protocol over TCP (DESIGN boundary 1).

PX4's ``simulator_mavlink`` module (``SimulatorMavlink.cpp``) is a TCP *client*: instance i
connects to port 4560+i of the simulator (``simulator_mavlink start -c 4560+i``, or ``-h HOST``
with ``PX4_SIM_HOSTNAME``), retrying every half second until it is accepted; Gazebo-classic's
``mavlink_interface`` plugin is the listening side. This module is that side for the PyBullet
world: one listening socket per vehicle, one autopilot per socket (PX4 SITL, a Pixhawk bridged
to TCP, our own emulator as ``swarmsitl autopilot``, or a pymavlink script).

What crosses, all MAVLink 2 on the TCP byte stream, one message per ``send`` as PX4 frames them:

* out: HIL_SENSOR (IMU rate; ``fields_updated`` flags the magnetometer and barometer when they
  were sampled; ``id`` 0, the IMU PX4's lockstep follows), HIL_GPS (GPS rate), DISTANCE_SENSOR
  (range finders), BATTERY_STATUS (the power module: PX4 ignores it and simulates its own
  battery; our emulator reads it), HIL_STATE_QUATERNION (ground truth, at the interval the
  autopilot asks for with MAV_CMD_SET_MESSAGE_INTERVAL, as PX4 does at connection: 5 ms), a
  COMMAND_ACK to that command, and the simulator's HEARTBEAT at 1 Hz.
* in: HIL_ACTUATOR_CONTROLS (``controls`` motor commands 0..1 in the airframe's rotor order,
  ``mode`` with MAV_MODE_FLAG_SAFETY_ARMED when armed, ``flags`` bit 0 = lockstep), HEARTBEAT
  (PX4 sends one first), COMMAND_LONG. Anything else is counted and ignored.

HEARTBEAT first: PX4 sends a HEARTBEAT as soon as it is connected, "to initiate the simulator to
start sending sensor data" (its own comment); HIL data goes to an autopilot only once its
HEARTBEAT arrived. The simulator's own HEARTBEAT goes to every connection at 1 Hz (PX4 on a
Pixhawk's USB port starts MAVLink on it).

Time base: every message carries simulation time (``time_usec``, ``time_boot_ms``); PX4 sets its
clock from HIL_SENSOR ``time_usec``.

Lockstep, as Gazebo's plugin does it: after the simulator sent a HIL_SENSOR to an autopilot
whose HIL_ACTUATOR_CONTROLS carry the lockstep flag (``flags`` bit 0: PX4 SITL built with its
lockstep scheduler, the default, and ``swarmsitl autopilot``), the next physics step waits until
that autopilot's reply arrives; the reply is applied at the next step, exactly where the
in-memory mode applies it, so the same seed flies the same trajectory, paced or as fast as
possible. Before an autopilot's first actuator message nothing waits (PX4 needs sensor data to
start its clock). An autopilot without the flag (a Pixhawk in HITL runs on its own clock) is
never waited for: the latest command received is applied at each step.
``HilServerConfig.lockstep = False`` ignores the flag.

Failures never hang the simulation: a peer that disconnects, stalls (no reply within
``stall_timeout_s`` of wall time in lockstep; without lockstep no actuator message for
``actuator_timeout_s`` of simulation time; or its receive buffer full) or only sends garbage is
logged, and its vehicle's motors stop, as ESCs stop when their signal is lost. A new connection
to a lost vehicle's port takes it over; a second autopilot connecting to a vehicle that already
has one is refused (accepted and closed, logged).
"""

from __future__ import annotations

import errno
import logging
import select
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl import hil
from sitl.hil_serial import SerialPort, UdpRelay, parse_serial
from sitl.truth import TruthState

log = logging.getLogger(__name__)

HIL_PORT_BASE = 4560
"""PX4's simulator port of instance 0 (``px4-rc.simulator``: 4560 + instance)."""
SIM_COMPID = 51
"""Component id of the simulator's own messages (PX4 does not check it)."""
OUT_BUFFER_LIMIT_BYTES = 4 * 1024 * 1024
"""Bytes queued for a peer that does not read before it is dropped as stalled."""
_LISTEN, _CONNECTION, _RELAY = "listen", "connection", "relay"
"""What a polled descriptor is: a listening port, an autopilot's connection, a HITL relay."""
_STOPPED = mavlink2.MAVLink_hil_actuator_controls_message(0, [0.0] * 16, 0, 0)
"""What a vehicle whose autopilot is lost gets: disarmed, every motor stopped."""


class HilPortInUseError(OSError):
    """The HIL port of a vehicle is taken (another simulator listens there)."""


@dataclass(frozen=True)
class HilServerConfig:
    """Where the simulator listens and how it waits."""

    n_vehicles: int = 1
    bind_addr: str = "127.0.0.1"
    """Address the HIL ports listen on (0.0.0.0: autopilots on other machines, e.g. PX4 with
    PX4_SIM_HOSTNAME)."""
    port_base: int = HIL_PORT_BASE
    """TCP port of vehicle 0 (+i for vehicle i); 0: the OS picks each port."""
    lockstep: bool = True
    """Wait for the replies of autopilots that flag lockstep (False: never wait)."""
    stall_timeout_s: float = 10.0
    """Wall seconds a lockstep step waits for a reply before the autopilot is declared lost."""
    actuator_timeout_s: float = 1.0
    """Autopilots not in lockstep: simulated seconds without an actuator message after which
    the motors stop."""
    serial: tuple[str, ...] = ()
    """HITL: one serial device per vehicle (``/dev/ttyACM0`` or ``/dev/ttyACM0:921600``), a
    Pixhawk's USB port, instead of the TCP ports (``sitl.hil_serial``); empty: TCP."""
    relay_addr: str = "127.0.0.1"
    """HITL: where the board's other MAVLink traffic is relayed (ground station, offboard API)."""
    relay_gcs_port: int = 14550
    """HITL: UDP port of the ground station the board's traffic goes to; 0: none."""
    relay_sdk_base: int = 14540
    """HITL: UDP port (+i) of vehicle i's offboard API the board's traffic goes to; 0: none."""

    def __post_init__(self) -> None:
        if self.n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {self.n_vehicles}")
        if not 0 <= self.port_base <= 65535 - (self.n_vehicles - 1):
            raise ValueError(f"port_base must be 0..65535 for every vehicle, got {self.port_base}")
        for name in ("stall_timeout_s", "actuator_timeout_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.serial:
            if len(self.serial) != self.n_vehicles:
                raise ValueError(
                    f"serial: one device per vehicle ({self.n_vehicles}), got {len(self.serial)}"
                )
            for spec in self.serial:
                parse_serial(spec)


@dataclass
class HilPeerStats:
    """What one vehicle's HIL connection carried (cumulative over reconnections)."""

    connections: int = 0
    refused: int = 0
    """Second autopilots refused while this one was connected."""
    messages_in: int = 0
    actuator_messages: int = 0
    bad_frames: int = 0
    """Bytes that did not parse as MAVLink (pymavlink's bad-data reports)."""
    ignored_messages: int = 0
    disconnects: int = 0
    stalls: int = 0
    bytes_out: int = 0


@dataclass
class _Peer:
    """One vehicle's HIL port and its current autopilot connection."""

    index: int
    listener: socket.socket | None
    """The TCP port it listens on (None: a serial peer)."""
    sock: socket.socket | SerialPort | None = None
    relay: UdpRelay | None = None
    """HITL: the UDP side of the board's other MAVLink traffic."""
    where: str = ""
    address: tuple[str, int] | None = None
    mav: mavlink2.MAVLink = field(default=None)  # type: ignore[assignment]
    out: bytearray = field(default_factory=bytearray)
    heartbeat: bool = False
    """It has sent a HEARTBEAT since connecting: HIL data goes to it from then on."""
    replying: bool = False
    """An actuator message arrived since connecting."""
    lockstep: bool = False
    """Its latest actuator message flagged lockstep (and the server honours it): steps wait."""
    awaiting: bool = False
    """A HIL_SENSOR went out that this peer has not answered yet."""
    latest: mavlink2.MAVLink_hil_actuator_controls_message | None = None
    last_actuator_sim_s: float = 0.0
    state_interval_s: float = 0.0
    next_state_s: float = 0.0
    stats: HilPeerStats = field(default_factory=HilPeerStats)


class HilServer:
    """The simulator side of PX4's TCP simulator protocol, for N vehicles.

    Call in each physics step, in this order, what the in-memory fleet would be called with:
    ``send_gps``, ``send_sensors``, ``send_battery``, ``send_distance_sensors`` (each when due),
    ``send_state`` (every step; sends only when asked for), then ``actuators()`` before the next
    ``World.step`` (in lockstep it waits for the replies).
    """

    def __init__(self, config: HilServerConfig, sim_time_s: Callable[[], float]) -> None:
        self.config = config
        self._time_s = sim_time_s
        self.peers: list[_Peer] = []
        self._poller = select.poll()
        self._by_fd: dict[int, tuple[_Peer, str]] = {}
        try:
            for i in range(config.n_vehicles):
                if config.serial:
                    self.peers.append(self._open_serial(i))
                else:
                    listener = self._listen(i)
                    self.peers.append(
                        _Peer(i, listener, where=f"tcp {config.bind_addr}:"
                              f"{listener.getsockname()[1]}")
                    )  # fmt: skip
                    self._register(self.peers[-1], listener, _LISTEN)
        except BaseException:
            self.close()
            raise
        self._next_heartbeat_s = 0.0
        self._last_accel = np.zeros((config.n_vehicles, 3))
        self._pending_reply = False

    # -- sockets -------------------------------------------------------------------------------

    def _listen(self, i: int) -> socket.socket:
        port = self.config.port_base + i if self.config.port_base else 0
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            sock.bind((self.config.bind_addr, port))
        except OSError as exc:
            sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise HilPortInUseError(
                    errno.EADDRINUSE,
                    f"TCP {self.config.bind_addr}:{port} (simulator port of vehicle {i + 1}) is "
                    "already in use: another simulator (Gazebo, jMAVSim, a second swarmsitl) is "
                    "listening there; stop it or choose another --hil-port",
                ) from exc
            raise
        sock.listen(4)
        sock.setblocking(False)
        return sock

    def _open_serial(self, i: int) -> _Peer:
        """Vehicle i's board on its serial port, with its UDP relay (HITL)."""
        cfg = self.config
        device, baud = parse_serial(cfg.serial[i])
        port = SerialPort(device, baud)
        relay_peers = []
        if cfg.relay_gcs_port:
            relay_peers.append((cfg.relay_addr, cfg.relay_gcs_port))
        if cfg.relay_sdk_base:
            relay_peers.append((cfg.relay_addr, cfg.relay_sdk_base + i))
        peer = _Peer(i, None, where=f"serial {device} at {baud} baud")
        try:
            peer.relay = UdpRelay(cfg.bind_addr, tuple(relay_peers))
        except BaseException:
            port.close()
            raise
        self._register(peer, peer.relay, _RELAY)
        self._attach(peer, port, (device, baud))
        return peer

    def _register(
        self, peer: _Peer, sock: socket.socket | SerialPort | UdpRelay, kind: str
    ) -> None:
        self._poller.register(sock.fileno(), select.POLLIN)
        self._by_fd[sock.fileno()] = (peer, kind)

    def _unregister(self, sock: socket.socket | SerialPort) -> None:
        fd = sock.fileno()
        if fd in self._by_fd:
            self._poller.unregister(fd)
            del self._by_fd[fd]

    def ports(self) -> list[int]:
        """The TCP port each vehicle listens on (0 for a serial vehicle)."""
        return [0 if p.listener is None else p.listener.getsockname()[1] for p in self.peers]

    def describe(self, i: int) -> str:
        """Where vehicle i's autopilot connects: ``tcp ADDR:PORT`` or ``serial DEVICE at BAUD``."""
        return self.peers[i].where

    def relay_address(self, i: int) -> tuple[str, int] | None:
        """HITL: the UDP address vehicle i's relay sends from (clients may send to it)."""
        relay = self.peers[i].relay
        return None if relay is None else relay.sock.getsockname()

    @property
    def connected(self) -> list[bool]:
        """Whether each vehicle has an autopilot connected now."""
        return [p.sock is not None for p in self.peers]

    @property
    def greeted(self) -> list[bool]:
        """Whether each vehicle's autopilot is connected and has sent its HEARTBEAT."""
        return [p.sock is not None and p.heartbeat for p in self.peers]

    def stats(self) -> list[HilPeerStats]:
        """Each vehicle's connection counters."""
        return [p.stats for p in self.peers]

    def wait_for_autopilots(
        self, should_stop: Callable[[], bool] = lambda: False, timeout_s: float | None = None
    ) -> bool:
        """Block until every vehicle's autopilot has connected and sent its HEARTBEAT.

        Gazebo's plugin waits for the connection too; the HEARTBEAT is PX4's first message.

        Returns:
            True when all are there; False if ``should_stop()`` said so or the wall-clock
            ``timeout_s`` passed.
        """
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while not all(self.greeted):
            if should_stop() or (deadline is not None and time.monotonic() > deadline):
                return False
            self._service(0.1)
        return True

    def _accept(self, peer: _Peer) -> None:
        try:
            sock, address = peer.listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        if peer.sock is not None:
            peer.stats.refused += 1
            log.warning(
                "vehicle %d: refused a second autopilot from %s:%d (HIL port %d is flown by "
                "%s:%d)",
                peer.index + 1, *address, peer.listener.getsockname()[1], *peer.address,
            )  # fmt: skip
            sock.close()
            return
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._attach(peer, sock, address)

    def _attach(
        self, peer: _Peer, sock: socket.socket | SerialPort, address: tuple[str, int]
    ) -> None:
        peer.sock, peer.address = sock, address
        peer.mav = mavlink2.MAVLink(None, srcSystem=peer.index + 1, srcComponent=SIM_COMPID)
        peer.mav.robust_parsing = True
        peer.out.clear()
        peer.heartbeat = peer.replying = peer.lockstep = peer.awaiting = False
        peer.latest = None
        peer.state_interval_s = 0.0
        peer.stats.connections += 1
        self._register(peer, sock, _CONNECTION)
        log.info("vehicle %d: autopilot on %s (%s:%d)", peer.index + 1, peer.where, *address)

    def _drop(self, peer: _Peer, why: str, stall: bool = False) -> None:
        """Close the peer's connection; its motors stop."""
        if peer.sock is not None:
            self._unregister(peer.sock)
            peer.sock.close()
        peer.sock = None
        peer.replying = peer.lockstep = peer.awaiting = False
        peer.latest = _STOPPED
        if stall:
            peer.stats.stalls += 1
        else:
            peer.stats.disconnects += 1
        log.error(
            "vehicle %d: autopilot %s at t = %.3f s simulated; its motors stop (ESC signal "
            "lost) %s",
            peer.index + 1, why, self._time_s(),
            "for the rest of the run (serial)" if peer.listener is None
            else f"until an autopilot connects to {peer.where} again",
        )  # fmt: skip

    def _service(self, timeout_s: float) -> None:
        """Accept, read and flush whatever is ready, waiting at most ``timeout_s``."""
        for fd, _ in self._poller.poll(timeout_s * 1000.0):
            entry = self._by_fd.get(fd)
            if entry is None:
                continue
            peer, kind = entry
            if kind == _LISTEN:
                self._accept(peer)
            elif kind == _RELAY:
                for datagram in peer.relay.receive():
                    if peer.sock is not None:
                        peer.out += datagram
                if peer.sock is not None and peer.out:
                    self._flush(peer)
            elif peer.sock is not None and peer.sock.fileno() == fd:
                self._read(peer)

    def _read(self, peer: _Peer) -> None:
        try:
            data = peer.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError as exc:
            self._drop(peer, f"connection failed ({exc.strerror})")
            return
        if not data:
            self._drop(peer, "disconnected")
            return
        try:
            messages = peer.mav.parse_buffer(data) or []
        except Exception as exc:  # pymavlink raises on what it cannot frame even when robust
            peer.stats.bad_frames += 1
            log.warning("vehicle %d: unparseable HIL input (%s)", peer.index + 1, exc)
            return
        relay = peer.relay
        for msg in messages:
            self._on_message(peer, msg)
            if relay is not None and msg.get_type() != "BAD_DATA":
                relay.forward(msg.get_msgbuf())

    def _on_message(self, peer: _Peer, msg: mavlink2.MAVLink_message) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA":
            peer.stats.bad_frames += 1
            if peer.stats.bad_frames in (1, 10, 100, 1000) or peer.stats.bad_frames % 10000 == 0:
                log.warning(
                    "vehicle %d: %d malformed MAVLink frames from the autopilot so far",
                    peer.index + 1, peer.stats.bad_frames,
                )  # fmt: skip
            return
        peer.stats.messages_in += 1
        if kind == "HIL_ACTUATOR_CONTROLS":
            peer.stats.actuator_messages += 1
            peer.latest = msg
            peer.replying = True
            peer.lockstep = self.config.lockstep and bool(msg.flags & 1)
            peer.awaiting = False
            peer.last_actuator_sim_s = self._time_s()
        elif kind == "HEARTBEAT":
            peer.heartbeat = True
        elif kind == "COMMAND_LONG":
            self._on_command(peer, msg)
        else:
            peer.stats.ignored_messages += 1

    def _on_command(self, peer: _Peer, msg: mavlink2.MAVLink_command_long_message) -> None:
        """MAV_CMD_SET_MESSAGE_INTERVAL for HIL_STATE_QUATERNION (PX4 asks for 5 ms)."""
        result = mavlink2.MAV_RESULT_UNSUPPORTED
        if msg.command == mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL:
            if int(msg.param1) == mavlink2.MAVLINK_MSG_ID_HIL_STATE_QUATERNION:
                interval_us = msg.param2
                if interval_us == interval_us:  # not NaN
                    # An interval of 0 or below stops it (MAVLink: -1 off, 0 default: none here).
                    peer.state_interval_s = interval_us * 1e-6 if interval_us > 0 else 0.0
                    peer.next_state_s = self._time_s()
                    result = mavlink2.MAV_RESULT_ACCEPTED
                else:
                    result = mavlink2.MAV_RESULT_DENIED
        else:
            peer.stats.ignored_messages += 1
        self._queue(peer, mavlink2.MAVLink_command_ack_message(
            msg.command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
        ))  # fmt: skip

    def _queue(self, peer: _Peer, msg: mavlink2.MAVLink_message) -> None:
        if peer.sock is None:
            return
        peer.out += msg.pack(peer.mav)
        self._flush(peer)

    def _flush(self, peer: _Peer) -> None:
        try:
            sent = peer.sock.send(peer.out)
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError as exc:
            self._drop(peer, f"connection failed ({exc.strerror})")
            return
        peer.stats.bytes_out += sent
        del peer.out[:sent]
        if len(peer.out) > OUT_BUFFER_LIMIT_BYTES:
            self._drop(peer, "stopped reading (send buffer full)", stall=True)

    # -- the step ------------------------------------------------------------------------------

    def _send_each(self, msgs: Sequence[mavlink2.MAVLink_message | None]) -> None:
        for peer, msg in zip(self.peers, msgs, strict=True):
            if msg is not None and peer.heartbeat and peer.sock is not None:
                peer.out += msg.pack(peer.mav)

    def send_gps(self, msgs: Sequence[mavlink2.MAVLink_hil_gps_message]) -> None:
        """Queue one HIL_GPS per vehicle."""
        self._send_each(msgs)

    def send_sensors(self, msgs: Sequence[mavlink2.MAVLink_hil_sensor_message]) -> None:
        """Queue one HIL_SENSOR per vehicle; replying autopilots now owe an actuator message."""
        self._send_each(msgs)
        for peer, msg in zip(self.peers, msgs, strict=True):
            self._last_accel[peer.index] = (msg.xacc, msg.yacc, msg.zacc)
            if peer.sock is not None and peer.lockstep and peer.heartbeat:
                peer.awaiting = True
                self._pending_reply = True

    def send_battery(self, msgs: Sequence[mavlink2.MAVLink_battery_status_message]) -> None:
        """Queue one BATTERY_STATUS per vehicle."""
        self._send_each(msgs)

    def send_distance_sensors(
        self, msgs: Sequence[Sequence[mavlink2.MAVLink_distance_sensor_message]]
    ) -> None:
        """Queue each vehicle's DISTANCE_SENSOR messages."""
        for peer, mine in zip(self.peers, msgs, strict=True):
            if peer.sock is not None and peer.heartbeat:
                for msg in mine:
                    peer.out += msg.pack(peer.mav)

    def send_state(self, now_s: float, truth: Callable[[], TruthState]) -> None:
        """HIL_STATE_QUATERNION to the autopilots that asked for it and are due; HEARTBEAT 1 Hz."""
        due = [
            p for p in self.peers
            if p.sock is not None
            and p.heartbeat
            and p.state_interval_s > 0
            and now_s >= p.next_state_s - 1e-9
        ]  # fmt: skip
        if due:
            msgs = hil.hil_state_quaternion_messages(round(now_s * 1e6), truth(), self._last_accel)
            for p in due:
                p.out += msgs[p.index].pack(p.mav)
                p.next_state_s += p.state_interval_s
                if p.next_state_s <= now_s:
                    p.next_state_s = now_s + p.state_interval_s
        if now_s >= self._next_heartbeat_s:
            self._next_heartbeat_s = now_s + 1.0
            for p in self.peers:
                if p.sock is not None:
                    p.out += mavlink2.MAVLink_heartbeat_message(
                        mavlink2.MAV_TYPE_GENERIC, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0,
                        mavlink2.MAV_STATE_ACTIVE, 3,
                    ).pack(p.mav)  # fmt: skip

    def actuators(self) -> list[mavlink2.MAVLink_hil_actuator_controls_message | None] | None:
        """Send what was queued, read the replies, and return the commands for the next step.

        In lockstep this waits for every autopilot that owes a reply. Returns one entry per
        vehicle (None: keep its previous command) or None when nothing new arrived.
        """
        for p in self.peers:
            if p.sock is not None and p.out:
                self._flush(p)
        if self._pending_reply:
            self._pending_reply = False
            deadline = time.monotonic() + self.config.stall_timeout_s
            while True:
                self._service(0.0)
                waiting = [p for p in self.peers if p.awaiting and p.sock is not None]
                if not waiting:
                    break
                left = deadline - time.monotonic()
                if left <= 0:
                    for p in waiting:
                        self._drop(
                            p,
                            f"sent no HIL_ACTUATOR_CONTROLS for {self.config.stall_timeout_s:g} "
                            "s of wall time (lockstep)",
                            stall=True,
                        )
                    break
                self._service(min(left, 0.5))
        else:
            self._service(0.0)
        now = self._time_s()
        for p in self.peers:
            if (
                p.sock is not None
                and p.replying
                and not p.lockstep
                and now - p.last_actuator_sim_s > self.config.actuator_timeout_s
            ):
                self._drop(
                    p,
                    f"sent no HIL_ACTUATOR_CONTROLS for {self.config.actuator_timeout_s:g} s of "
                    "simulation time",
                    stall=True,
                )
        out = [p.latest for p in self.peers]
        for p in self.peers:
            p.latest = None
        return out if any(m is not None for m in out) else None

    def close(self) -> None:
        """Close every connection and listening socket."""
        for p in self.peers:
            if p.sock is not None:
                p.sock.close()
                p.sock = None
            if p.listener is not None:
                p.listener.close()
            if p.relay is not None:
                p.relay.close()
