"""Protocol fuzz of a flying vehicle's MAVLink endpoint (hypothesis, real in-process stack).

One :class:`harness.sim.simulation.Simulation` runs in lockstep with a UDP endpoint; a raw pymavlink
socket (sysid 245, compid 190, as MAVSDK) arms it and takes off, then throws at it: random bytes,
truncated frames, frames with a bad CRC, and well-formed MAVLink 2 frames of every message of the
common dialect filled with random values of the right types (targets biased to the vehicle, 1/1,
so the handlers run; commands biased to the ones the dispatcher implements). Properties, after
every example:

* no exception escapes ``Simulation.step`` (the endpoint's ``poll`` runs inside it);
* ``stats.handler_errors == 0`` and ``stats.encode_errors == 0``;
* nothing is logged at ERROR by an ``autopilot_emu`` logger;
* the vehicle still answers: MAV_CMD_REQUEST_MESSAGE(AUTOPILOT_VERSION) gets its COMMAND_ACK and
  the message within :data:`ANSWER_WITHIN_S` of simulation time.

Nothing is excluded: a fuzzed kill, termination or disarm is fine, the vehicle must still answer.
A vehicle that has been brought down is relaunched after :data:`RELAUNCH_EVERY` examples so that
most examples hit a flying vehicle: over UDP if it is upright, else (a kill in the air leaves it
on its back, from where it can never take off again) in a fresh simulation on the same ports.
The default run is bounded and seeded, without an example database (the same examples in every
CI run); ``pytest -m slow`` runs many more from another seed.

Known commander issue, found here and not fixed in this package: after NAV_LAND in the air
followed by DO_SET_MODE AUTO/LOITER, the vehicle hovers but EXTENDED_SYS_STATE keeps reporting
MAV_LANDED_STATE_LANDING (4) instead of IN_AIR (2); :meth:`FlyingVehicle.flying` therefore looks
at the altitude above home, not at the landed state.
"""

from __future__ import annotations

import logging
import math
import socket
from collections.abc import Callable
from dataclasses import dataclass, field

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st
from mavlink_fakes import INT_RANGES
from pymavlink.dialects.v20 import common as mavlink2

from harness.run.ports import free_port_block
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

pytestmark = pytest.mark.sockets

DEFAULT_EXAMPLES = 80
"""About a minute of the default suite (0.7 s per example); the slow test runs SLOW_EXAMPLES."""
DEFAULT_SEED = 1
"""Fixed seed (and no example database): CI runs the same examples every time."""
SLOW_EXAMPLES = 3000
SLOW_SEED = 20260101
STEPS_PER_EXAMPLE = 50
"""Physics steps run after the fuzz datagrams of one example (0.1 s at 500 Hz)."""
ANSWER_WITHIN_S = 1.0
"""Simulation time the vehicle has to answer the liveness request, s."""
LAUNCH_WITHIN_S = 120.0
"""Simulation time allowed to become armable, arm and climb, s."""
RELAUNCH_WITHIN_S = 10.0
"""Simulation time allowed to arm again once the estimator has converged, s."""
CLIMB_WITHIN_S = 30.0
"""Simulation time allowed to climb above 1 m after NAV_TAKEOFF, s (about 3 s unfuzzed)."""
CAPSIZED_TILT_RAD = math.radians(90.0)
"""True roll or pitch beyond which a vehicle on the ground is on its side or back."""
RELAUNCH_EVERY = 25
"""Examples between attempts to get a vehicle that is no longer flying back into the air."""
GCS_IDS = (245, 190)
VEHICLE = (1, 1)

_REQUEST_MESSAGE = mavlink2.MAV_CMD_REQUEST_MESSAGE
_AUTOPILOT_VERSION = mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION
_HANDLED_COMMANDS = (
    mavlink2.MAV_CMD_DO_SET_MODE,
    mavlink2.MAV_CMD_COMPONENT_ARM_DISARM,
    mavlink2.MAV_CMD_NAV_TAKEOFF,
    mavlink2.MAV_CMD_NAV_LAND,
    mavlink2.MAV_CMD_DO_REPOSITION,
    mavlink2.MAV_CMD_DO_CHANGE_SPEED,
    mavlink2.MAV_CMD_DO_SET_HOME,
    mavlink2.MAV_CMD_DO_FLIGHTTERMINATION,
    mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
    mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL,
    mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL,
    mavlink2.MAV_CMD_REQUEST_MESSAGE,
    mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    mavlink2.MAV_CMD_GET_HOME_POSITION,
    mavlink2.MAV_CMD_REQUEST_PROTOCOL_VERSION,
)
_SPECIAL_FLOATS = (
    0.0,
    -0.0,
    0.5,
    1.0,
    -1.0,
    -2.0,
    2.0,
    3.0,
    4.0,
    6.0,
    129.0,
    21196.0,
    47.3977,
    8.5456,
    488.0,
    500.0,
    1e6,
    float(2**31),
    90.5,
    -180.5,
    float(0xFFFF),
    float(0x10000),
    float(0x1000000),
    1e30,
    -1e30,
    3.4e38,
    1e-45,
    math.nan,
    math.inf,
    -math.inf,
)

# --- strategies ------------------------------------------------------------------------------


def _int_values(type_name: str) -> st.SearchStrategy[int]:
    low, high = INT_RANGES[type_name]
    edges = sorted({low, high, 0, 1, min(high, 2**31 - 1)})
    return st.one_of(st.sampled_from(edges), st.integers(low, high))


def _float_values(type_name: str) -> st.SearchStrategy[float]:
    width = 64 if type_name == "double" else 32
    return st.one_of(st.sampled_from(_SPECIAL_FLOATS), st.floats(width=width))


def _scalar(name: str, type_name: str, msg_id: int) -> st.SearchStrategy:
    if name == "target_system":
        return st.sampled_from((VEHICLE[0], VEHICLE[0], VEHICLE[0], 0, 2, 255))
    if name == "target_component":
        return st.sampled_from((VEHICLE[1], VEHICLE[1], VEHICLE[1], 0, 100, 190))
    if name == "command" and msg_id in (
        mavlink2.MAVLINK_MSG_ID_COMMAND_LONG,
        mavlink2.MAVLINK_MSG_ID_COMMAND_INT,
    ):
        return st.one_of(st.sampled_from(_HANDLED_COMMANDS), _int_values("uint16_t"))
    if type_name in ("float", "double"):
        return _float_values(type_name)
    if type_name == "char":
        return st.binary(min_size=1, max_size=1)
    return _int_values(type_name)


def _field(name: str, type_name: str, length: int, msg_id: int) -> st.SearchStrategy:
    if length == 0:
        return _scalar(name, type_name, msg_id)
    if type_name == "char":
        return st.binary(max_size=length)
    return st.lists(_scalar(name, type_name, msg_id), min_size=length, max_size=length)


def _message_strategy(cls: type) -> st.SearchStrategy[mavlink2.MAVLink_message]:
    """Instances of one pymavlink message class with random field values of the right types."""
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    fields = [
        _field(name, type_name, lengths[name], cls.id)
        for name, type_name in zip(cls.fieldnames, cls.fieldtypes, strict=True)
    ]
    return st.tuples(*fields).map(lambda values: cls(*values))


MESSAGE_CLASSES = tuple(sorted(mavlink2.mavlink_map.values(), key=lambda cls: cls.id))
"""Every message of pymavlink's common dialect."""
_BIASED_IDS = (
    mavlink2.MAVLINK_MSG_ID_COMMAND_LONG,
    mavlink2.MAVLINK_MSG_ID_COMMAND_INT,
    mavlink2.MAVLINK_MSG_ID_PARAM_SET,
    mavlink2.MAVLINK_MSG_ID_PARAM_REQUEST_READ,
    mavlink2.MAVLINK_MSG_ID_PARAM_REQUEST_LIST,
    mavlink2.MAVLINK_MSG_ID_PING,
)
"""Messages the endpoint handles: drawn as often as all the others together, and commands
as often again."""


def _any_message() -> st.SearchStrategy[mavlink2.MAVLink_message]:
    everything = st.sampled_from(MESSAGE_CLASSES)
    handled = st.sampled_from([mavlink2.mavlink_map[i] for i in _BIASED_IDS])
    commands = st.sampled_from([mavlink2.mavlink_map[i] for i in _BIASED_IDS[:2]])
    return st.one_of(everything, handled, commands).flatmap(_message_strategy)


class FrameEncoder:
    """MAVLink 2 encoder posing as the ground station (245/190)."""

    def __init__(self) -> None:
        self._mav = mavlink2.MAVLink(None, srcSystem=GCS_IDS[0], srcComponent=GCS_IDS[1])

    def pack(self, msg: mavlink2.MAVLink_message) -> bytes:
        frame = msg.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) & 0xFF
        return frame


_SPECIALS = st.sampled_from(_SPECIAL_FLOATS)
_PARAMS = st.one_of(_SPECIALS, _SPECIALS, _SPECIALS, st.floats(width=32))
_COORDINATES = st.one_of(
    st.sampled_from((0, 2**31 - 1, -(2**31), 0x7FF80000, 473977420, 85455940, 900_000_001)),
    _int_values("int32_t"),
)


@st.composite
def _command(draw: st.DrawFn) -> mavlink2.MAVLink_message:
    """COMMAND_LONG or COMMAND_INT of an implemented command, parameters biased to edge values."""
    target = draw(st.sampled_from((VEHICLE,) * 4 + ((0, 0), (1, 100), (2, 1))))
    command = draw(st.sampled_from(_HANDLED_COMMANDS))
    params = [draw(_PARAMS) for _ in range(4)]
    if draw(st.booleans()):
        frame = draw(st.sampled_from((0, 3, 5, 6, 1, 255)))
        x, y = draw(_COORDINATES), draw(_COORDINATES)
        return mavlink2.MAVLink_command_int_message(
            *target, frame, command, 0, 0, *params, x, y, draw(_PARAMS)
        )
    position = [draw(_PARAMS) for _ in range(3)]
    return mavlink2.MAVLink_command_long_message(*target, command, 0, *params, *position)


@st.composite
def _datagram(draw: st.DrawFn, encoder: FrameEncoder) -> bytes:
    """One UDP payload: junk, a truncated or corrupted frame, valid frames, or a command."""
    kind = draw(st.sampled_from(("random", "truncated", "bad_crc", "valid", "command", "command")))
    if kind == "command":
        return encoder.pack(draw(_command()))
    if kind == "random":
        junk = draw(st.binary(max_size=300))
        return draw(st.sampled_from((b"", b"\xfd", b"\xfe"))) + junk
    if kind == "valid":
        messages = draw(st.lists(_any_message(), min_size=1, max_size=3))
        return b"".join(encoder.pack(msg) for msg in messages)
    frame = bytearray(encoder.pack(draw(_any_message())))
    if kind == "truncated":
        return bytes(frame[: draw(st.integers(1, len(frame) - 1))])
    position = draw(st.integers(1, len(frame) - 1))  # never the start marker
    frame[position] ^= draw(st.integers(1, 255))
    return bytes(frame)


# --- the vehicle under test ------------------------------------------------------------------


def _free_udp_port() -> int:
    """A port nobody holds, from the suite's allocator (this xdist worker's own slice)."""
    return free_port_block()


def _simulation(listen_port: int, gcs_port: int) -> Simulation:
    """One lockstep vehicle listening on ``listen_port`` and streaming to ``gcs_port``."""
    ports = PortPlan(bind_addr="127.0.0.1", listen_base=listen_port, sdk_base=gcs_port, gcs_port=0)
    return Simulation(SimulationConfig(mavlink=True, ports=ports, record_hz=0))


@dataclass
class FlyingVehicle:
    """A lockstep simulation of one vehicle and a raw UDP ground station talking to it."""

    sim: Simulation
    sock: socket.socket
    listen_port: int
    encoder: FrameEncoder = field(default_factory=FrameEncoder)
    parser: mavlink2.MAVLink = field(
        default_factory=lambda: mavlink2.MAVLink(None, GCS_IDS[0], GCS_IDS[1])
    )
    examples_since_launch: int = 0
    launches: int = 0
    replacements: int = 0
    failed_relaunches: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.parser.robust_parsing = True

    @property
    def stats(self):
        return self.sim.endpoints[0].stats

    def send_raw(self, data: bytes) -> None:
        self.sock.sendto(data, ("127.0.0.1", self.listen_port))

    def send(self, msg: mavlink2.MAVLink_message) -> None:
        self.send_raw(self.encoder.pack(msg))

    def receive(self) -> list[mavlink2.MAVLink_message]:
        received: list[mavlink2.MAVLink_message] = []
        while True:
            try:
                data = self.sock.recv(65535)
            except BlockingIOError:
                return received
            received.extend(self.parser.parse_buffer(data) or [])

    def step_until(
        self, done: Callable[[list[mavlink2.MAVLink_message]], bool], within_s: float
    ) -> bool:
        """Step the simulation until ``done(new messages)`` holds or ``within_s`` simulated s."""
        end = self.sim.time_s + within_s
        while self.sim.time_s < end:
            for _ in range(self.sim._poll_every):
                self.sim.step()
            if done(self.receive()):
                return True
        return False

    def command(self, command: int, *params: float) -> None:
        padded = list(params) + [math.nan] * (7 - len(params))
        self.send(mavlink2.MAVLink_command_long_message(*VEHICLE, command, 0, *padded))

    def flying(self) -> bool:
        """Armed and above 1 m (landed_state alone is not trusted: see the module docstring)."""
        snapshot = self.sim.fleet.vehicle(0).telemetry()
        return snapshot.armed and snapshot.relative_alt_m > 1.0

    def launch(self) -> bool:
        """Over UDP: undo what the fuzz may have changed, ARM (until armable), NAV_TAKEOFF, climb.

        Returns whether the vehicle is flying again; the fuzz may have left it unable to (a crash
        after a kill can leave it on its back), which is no failure of the endpoint.
        """
        self.examples_since_launch = 0
        self.command(mavlink2.MAV_CMD_DO_SET_MODE, 1, 4, 3)
        self.command(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 0, 21196)  # kill any leftovers
        self.command(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, -2, -2)
        self.step_until(lambda _: False, 0.5)
        self.command(mavlink2.MAV_CMD_DO_SET_HOME, 1)
        deadline = self.sim.time_s + (RELAUNCH_WITHIN_S if self.launches else LAUNCH_WITHIN_S)
        while not self.sim.fleet.vehicle(0).telemetry().armed:
            if self.sim.time_s > deadline:
                return False
            self.command(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            self.step_until(lambda _: False, 0.5)
        self.command(mavlink2.MAV_CMD_NAV_TAKEOFF)
        self.launches += 1
        return self.step_until(lambda _: self.flying(), CLIMB_WITHIN_S)

    def capsized(self) -> bool:
        """On its side or back (true attitude): no take-off can right it."""
        roll_pitch = self.sim.world.truth.euler_ned_frd_rad[0, :2]
        return bool(max(abs(roll_pitch)) > CAPSIZED_TILT_RAD)

    def replace(self) -> bool:
        """Close the simulation, start a fresh one on the same ports and launch it."""
        self.sim.close()
        self.sim = _simulation(self.listen_port, self.sock.getsockname()[1])
        self.launches = 0
        self.replacements += 1
        self.receive()
        return self.launch()

    def relaunch(self) -> bool:
        """Back into the air: over UDP if upright, else in a fresh simulation."""
        if not self.capsized() and self.launch():
            return True
        return self.replace()

    def answers(self) -> bool:
        """REQUEST_MESSAGE(AUTOPILOT_VERSION) -> ACCEPTED ACK and the message, in sim time."""
        self.receive()
        self.command(_REQUEST_MESSAGE, _AUTOPILOT_VERSION)
        seen: set[str] = set()

        def answered(messages: list[mavlink2.MAVLink_message]) -> bool:
            for msg in messages:
                if msg.get_type() == "AUTOPILOT_VERSION":
                    seen.add("version")
                elif (
                    msg.get_type() == "COMMAND_ACK"
                    and msg.command == _REQUEST_MESSAGE
                    and msg.result == mavlink2.MAV_RESULT_ACCEPTED
                    and (msg.target_system, msg.target_component) == GCS_IDS
                ):
                    seen.add("ack")
            return seen == {"version", "ack"}

        return self.step_until(answered, ANSWER_WITHIN_S)


@pytest.fixture(scope="module")
def vehicle():
    """One flying vehicle for the module (getting armable takes ~20 s of simulated time)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.setblocking(False)
    listen_port = _free_udp_port()
    flying = FlyingVehicle(_simulation(listen_port, sock.getsockname()[1]), sock, listen_port)
    try:
        assert flying.launch(), "vehicle did not take off"
        yield flying
    finally:
        flying.sim.close()
        sock.close()


# --- the properties --------------------------------------------------------------------------


def _errors(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [
        f"{r.name}: {r.getMessage()}"
        for r in caplog.records
        if r.levelno >= logging.ERROR and r.name.startswith("autopilot_emu")
    ]


def _fuzz(vehicle: FlyingVehicle, caplog: pytest.LogCaptureFixture, examples: int) -> Callable:
    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    @given(_command(), st.lists(_datagram(vehicle.encoder), max_size=5))
    def run(command: mavlink2.MAVLink_message, datagrams: list[bytes]) -> None:
        relaunch = vehicle.examples_since_launch >= RELAUNCH_EVERY and not vehicle.flying()
        if relaunch and not vehicle.relaunch():
            snapshot = vehicle.sim.fleet.vehicle(0).telemetry()
            vehicle.failed_relaunches.append(str(snapshot))
        vehicle.examples_since_launch += 1
        caplog.clear()
        vehicle.send(command)
        for data in datagrams:
            vehicle.send_raw(data)
        vehicle.step_until(lambda _: False, STEPS_PER_EXAMPLE / vehicle.sim.config.physics_hz)
        assert vehicle.stats.handler_errors == 0
        assert vehicle.stats.encode_errors == 0
        assert _errors(caplog) == []
        assert vehicle.answers(), "no COMMAND_ACK + AUTOPILOT_VERSION after the fuzz input"

    return run


@pytest.mark.parametrize("cls", MESSAGE_CLASSES, ids=lambda cls: cls.msgname)
def test_every_common_message_type_can_be_generated_and_packed(cls):
    """The generator covers the whole dialect: random instances of each message pack and parse."""
    encoder = FrameEncoder()
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True

    @settings(max_examples=3, deadline=None, database=None, derandomize=True)
    @given(_message_strategy(cls))
    def check(msg: mavlink2.MAVLink_message) -> None:
        (decoded,) = parser.parse_buffer(encoder.pack(msg))
        assert decoded.get_msgId() == cls.id

    check()


def test_flying_vehicle_survives_protocol_fuzz(vehicle, caplog):
    """Fuzzed datagrams never raise, never log errors and never stop the vehicle answering."""
    caplog.set_level(logging.INFO, logger="autopilot_emu")
    seed(DEFAULT_SEED)(_fuzz(vehicle, caplog, DEFAULT_EXAMPLES))()
    assert vehicle.failed_relaunches == [], "a fresh simulation did not take off"


@pytest.mark.slow
def test_flying_vehicle_survives_long_protocol_fuzz(vehicle, caplog):
    """The same properties over many more examples, from a fixed seed."""
    caplog.set_level(logging.INFO, logger="autopilot_emu")
    seed(SLOW_SEED)(_fuzz(vehicle, caplog, SLOW_EXAMPLES))()
    assert vehicle.failed_relaunches == [], "a fresh simulation did not take off"
