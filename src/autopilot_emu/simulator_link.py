"""The autopilot's end of PX4's simulator protocol over TCP: what PX4's ``simulator_mavlink`` does.

PX4 SITL instance i connects to a simulator listening on TCP 4560+i, retrying every 0.5 s until
it is accepted (``SimulatorMavlink::run``), sends one HEARTBEAT (autopilot MAV_AUTOPILOT_PX4, the
armed flag in ``base_mode``) and asks for HIL_STATE_QUATERNION every 5 ms with
MAV_CMD_SET_MESSAGE_INTERVAL. From then on every HIL_SENSOR moves its clock (``time_usec``) and
every control cycle answers with one HIL_ACTUATOR_CONTROLS (``mode`` = custom mode flag + armed
flag, ``flags`` = 1 with the lockstep scheduler). :class:`SimulatorLink` does the same for an
:class:`~autopilot_emu.fleet.AutopilotFleet` of one vehicle: it feeds HIL_SENSOR, HIL_GPS,
BATTERY_STATUS and DISTANCE_SENSOR to the fleet, exactly as the in-memory mode hands them over,
and sends the fleet's reply to each HIL_SENSOR at once, so the simulator's lockstep sees the
same commands at the same steps as in memory.

HIL_STATE_QUATERNION (ground truth) is read and kept (:attr:`SimulatorLink.ground_truth`) but
never used by the flight stack, as in PX4. Malformed input is counted, never raised.
"""

from __future__ import annotations

import logging
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.fleet import AutopilotFleet

log = logging.getLogger(__name__)

RETRY_S = 0.5
"""Wall seconds between two connection attempts (PX4: ``system_usleep(500)`` between tries,
i.e. as fast as it can; half a second keeps the log readable)."""
STATE_INTERVAL_US = 5000.0
"""HIL_STATE_QUATERNION interval PX4 asks the simulator for, us."""
LOCKSTEP_FLAG = 1
"""HIL_ACTUATOR_CONTROLS ``flags`` bit: the autopilot runs in lockstep with the simulator."""


@dataclass(frozen=True)
class SimulatorLinkConfig:
    """Where the simulator is and how to talk to it."""

    host: str = "127.0.0.1"
    port: int = 4560
    """The simulator's TCP port of this vehicle (4560 + instance)."""
    lockstep: bool = True
    """Flag lockstep in HIL_ACTUATOR_CONTROLS (the simulator then waits for every reply)."""

    def __post_init__(self) -> None:
        if not 1 <= self.port <= 65535:
            raise ValueError(f"port must be 1..65535, got {self.port}")


@dataclass
class SimulatorLinkStats:
    """What the link carried."""

    sensor_messages: int = 0
    gps_messages: int = 0
    battery_messages: int = 0
    distance_messages: int = 0
    state_messages: int = 0
    actuator_messages: int = 0
    bad_frames: int = 0
    ignored_messages: int = 0


class SimulatorLink:
    """One vehicle's connection to a simulator speaking PX4's protocol (the TCP client)."""

    def __init__(self, fleet: AutopilotFleet, config: SimulatorLinkConfig) -> None:
        if fleet.n != 1:
            raise ValueError(f"one simulator link drives one vehicle, the fleet has {fleet.n}")
        self.fleet = fleet
        self.config = config
        self.sock: socket.socket | None = None
        sysid = int(fleet.params[0].get("MAV_SYS_ID"))
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=1)
        self.mav.robust_parsing = True
        self.stats = SimulatorLinkStats()
        self.ground_truth: mavlink2.MAVLink_hil_state_quaternion_message | None = None
        """The latest HIL_STATE_QUATERNION (the simulator's true state), if any."""
        self.time_s = 0.0
        """Simulation time of the latest HIL_SENSOR, s (the autopilot's clock)."""
        self.closed_by_peer = False

    def connect(
        self, should_stop: Callable[[], bool] = lambda: False, timeout_s: float | None = None
    ) -> bool:
        """Connect (retrying until accepted), then greet as PX4: HEARTBEAT, interval request.

        Returns:
            Whether it connected (False: ``should_stop()`` or the wall-clock timeout).
        """
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        address = (self.config.host, self.config.port)
        while True:
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            try:
                sock.connect(address)
                break
            except OSError:
                sock.close()
            if should_stop() or (deadline is not None and time.monotonic() > deadline):
                return False
            time.sleep(RETRY_S)
        sock.setblocking(True)
        self.sock = sock
        log.info("connected to the simulator at %s:%d", *address)
        armed = bool(self.fleet.armed[0])
        self._send(
            mavlink2.MAVLink_heartbeat_message(
                mavlink2.MAV_TYPE_GENERIC,
                mavlink2.MAV_AUTOPILOT_PX4,
                mavlink2.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0,
                0,
                0,
                3,
            )
        )
        self._send(
            mavlink2.MAVLink_command_long_message(
                0, 0, mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                mavlink2.MAVLINK_MSG_ID_HIL_STATE_QUATERNION, STATE_INTERVAL_US, 0, 0, 0, 0, 0,
            )
        )  # fmt: skip
        return True

    def fileno(self) -> int:
        """The TCP socket's descriptor (for select/poll)."""
        if self.sock is None:
            raise RuntimeError("not connected")
        return self.sock.fileno()

    def _send(self, msg: mavlink2.MAVLink_message) -> None:
        self.sock.sendall(msg.pack(self.mav))

    def receive(self) -> bool:
        """Read what the simulator sent (the socket is readable) and act on every message.

        Returns:
            Whether a HIL_SENSOR moved the clock; False with :attr:`closed_by_peer` set when the
            simulator closed the connection.
        """
        try:
            data = self.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return False
        except OSError as exc:
            log.error("simulator connection failed: %s", exc)
            data = b""
        if not data:
            self.closed_by_peer = True
            return False
        try:
            messages = self.mav.parse_buffer(data) or []
        except Exception as exc:  # pymavlink raises on what it cannot frame even when robust
            self.stats.bad_frames += 1
            log.warning("unparseable simulator input: %s", exc)
            return False
        ticked = False
        ranges: list[mavlink2.MAVLink_distance_sensor_message] = []
        for msg in messages:
            if msg.get_type() == "DISTANCE_SENSOR":
                ranges.append(msg)  # one call per run of them, as in memory
                continue
            if ranges:
                self._on_ranges(ranges)
                ranges = []
            ticked |= self._on_message(msg)
        if ranges:
            self._on_ranges(ranges)
        return ticked

    def _on_ranges(self, msgs: list[mavlink2.MAVLink_distance_sensor_message]) -> None:
        self.stats.distance_messages += len(msgs)
        self.fleet.handle_distance_sensors([msgs])

    def _on_message(self, msg: mavlink2.MAVLink_message) -> bool:
        kind = msg.get_type()
        fleet = self.fleet
        if kind == "HIL_SENSOR":
            self.stats.sensor_messages += 1
            if msg.id != 0:
                self.stats.ignored_messages += 1  # only IMU 0 is simulated here
                return False
            reply = fleet.handle_sensors([msg])[0]
            self.time_s = msg.time_usec * 1e-6
            reply.flags = LOCKSTEP_FLAG if self.config.lockstep else 0
            self._send(reply)
            self.stats.actuator_messages += 1
            return True
        if kind == "HIL_GPS":
            self.stats.gps_messages += 1
            fleet.handle_gps([msg])
        elif kind == "BATTERY_STATUS":
            self.stats.battery_messages += 1
            fleet.handle_battery([msg])
        elif kind == "HIL_STATE_QUATERNION":
            self.stats.state_messages += 1
            self.ground_truth = msg
        elif kind == "BAD_DATA":
            self.stats.bad_frames += 1
            if self.stats.bad_frames in (1, 10, 100) or self.stats.bad_frames % 1000 == 0:
                log.warning("%d malformed frames from the simulator so far", self.stats.bad_frames)
        else:
            self.stats.ignored_messages += 1  # HEARTBEAT, COMMAND_ACK, RC, ...
        return False

    def close(self) -> None:
        """Close the connection."""
        if self.sock is not None:
            self.sock.close()
            self.sock = None
