"""MAVLink command protocol: COMMAND_LONG / COMMAND_INT -> vehicle call -> MAV_RESULT.

:class:`CommandRequest` normalises both messages. :class:`CommandDispatcher` validates the
parameters (a NaN or infinity where a number is required -> DENIED), calls the vehicle or the
endpoint services, and turns exceptions into FAILED so every command is answered. Retransmissions
are idempotent: a command identical to the previous *accepted* one from the same source within
:data:`DUPLICATE_WINDOW_S` of wall time is answered with the cached result and not executed again
(MAVSDK retries on a wall-clock timer, whatever the simulation speed); a refused command has no
side effect and is simply executed again, since the vehicle may have become ready. Pure requests
(REQUEST_MESSAGE and its legacy forms, GET_MESSAGE_INTERVAL) are always executed, since repeating
them has no side effect and a retry usually means the reply was lost.

Command semantics follow MAVSDK_CONTRACT.md sections 2-4 and 12.6.
"""

from __future__ import annotations

import logging
import math
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.vehicle_port import VehiclePort

logger = logging.getLogger(__name__)

DUPLICATE_WINDOW_S = 2.0
"""Wall-clock window in which an identical command counts as a retransmission, s."""
FORCE_MAGIC = 21196.0
"""ARM_DISARM param2 value that forces arming / kills the motors in the air."""

ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
TEMPORARILY_REJECTED = mavlink2.MAV_RESULT_TEMPORARILY_REJECTED
DENIED = mavlink2.MAV_RESULT_DENIED
UNSUPPORTED = mavlink2.MAV_RESULT_UNSUPPORTED
FAILED = mavlink2.MAV_RESULT_FAILED

_INT32_MAX = 2**31 - 1
_AMSL_FRAMES = frozenset({mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_INT})
_RELATIVE_FRAMES = frozenset(
    {mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT}
)
_REQUESTS = frozenset(
    {
        mavlink2.MAV_CMD_REQUEST_MESSAGE,
        mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
        mavlink2.MAV_CMD_GET_HOME_POSITION,
        mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL,
    }
)
_LONG_KEY = struct.Struct("<7f")
_INT_KEY = struct.Struct("<4fiifB")


@dataclass(frozen=True)
class CommandRequest:
    """A COMMAND_LONG or COMMAND_INT as the dispatcher sees it."""

    command: int
    """MAV_CMD id."""
    params: tuple[float, float, float, float]
    """param1..param4."""
    x: float
    """COMMAND_LONG param5, or COMMAND_INT x (int32, degE7 for global frames)."""
    y: float
    """COMMAND_LONG param6, or COMMAND_INT y."""
    z: float
    """COMMAND_LONG param7, or COMMAND_INT z."""
    frame: int | None
    """COMMAND_INT frame; None for COMMAND_LONG."""
    source: tuple[int, int]
    """Sender's (sysid, compid) from the frame header."""

    @classmethod
    def from_message(cls, msg: mavlink2.MAVLink_message) -> CommandRequest:
        """Build from a decoded COMMAND_LONG or COMMAND_INT."""
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        params = (msg.param1, msg.param2, msg.param3, msg.param4)
        if msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_COMMAND_INT:
            return cls(msg.command, params, msg.x, msg.y, msg.z, msg.frame, source)
        return cls(msg.command, params, msg.param5, msg.param6, msg.param7, None, source)

    def identity(self) -> tuple[int, int | None, bytes]:
        """What makes two commands "identical" for retransmission detection."""
        if self.frame is None:
            raw = _LONG_KEY.pack(*self.params, self.x, self.y, self.z)
        else:
            raw = _INT_KEY.pack(*self.params, int(self.x), int(self.y), self.z, self.frame)
        return (self.command, self.frame, raw)


class CommandServices(Protocol):
    """What the dispatcher needs from the endpoint itself (messages and streams)."""

    def request_message(self, msg_id: int) -> int:
        """Queue one ``msg_id`` after the ACK; return the MAV_RESULT."""
        ...

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        """Change a stream interval (0 default, -1 stop); return the MAV_RESULT."""
        ...

    def report_message_interval(self, msg_id: int) -> int:
        """Queue MESSAGE_INTERVAL for ``msg_id`` after the ACK; return the MAV_RESULT."""
        ...

    def announce(self, severity: int, text: str) -> None:
        """Send a STATUSTEXT."""
        ...

    def home_alt_amsl_m(self) -> float | None:
        """Home altitude AMSL, m; None while there is no home."""
        ...


@dataclass(frozen=True)
class CommandReply:
    """Outcome of one received command."""

    result: int
    """MAV_RESULT to put in COMMAND_ACK."""
    duplicate: bool
    """True if this was a retransmission answered from the cache."""


@dataclass(frozen=True)
class _Handled:
    """The last command executed for one source."""

    identity: tuple[int, int | None, bytes]
    result: int
    wall_time_s: float
    state: tuple[bool, int, int]
    """Armed flag and PX4 mode right after execution: a retransmission is only recognised while
    they still hold (a vehicle that auto-disarmed in between is armed again by a repeated ARM)."""


class _Rejected(Exception):
    """Raised inside handlers to answer with ``result`` (DENIED, UNSUPPORTED, ...)."""

    def __init__(self, result: int, reason: str) -> None:
        super().__init__(reason)
        self.result = result


def _finite(value: float) -> bool:
    return math.isfinite(value)


def _required(value: float, what: str) -> float:
    """``value`` if finite, else reject with DENIED."""
    if not math.isfinite(value):
        raise _Rejected(DENIED, f"{what} must be a finite number, got {value}")
    return value


def _optional(value: float, what: str) -> float:
    """``value`` if finite or NaN ("keep current"), else reject with DENIED."""
    if math.isinf(value):
        raise _Rejected(DENIED, f"{what} must be finite or NaN, got {value}")
    return value


class CommandDispatcher:
    """Executes commands on one vehicle.

    Args:
        vehicle: the flight stack.
        services: endpoint-side operations (message requests, stream intervals, STATUSTEXT).
        wall_clock_s: monotonic wall clock used only for retransmission detection.
    """

    def __init__(
        self,
        vehicle: VehiclePort,
        services: CommandServices,
        wall_clock_s: Callable[[], float] = time.monotonic,
    ) -> None:
        self._vehicle = vehicle
        self._services = services
        self._wall_clock_s = wall_clock_s
        self._last_by_source: dict[tuple[int, int], _Handled] = {}
        self._handlers: dict[int, Callable[[CommandRequest], int]] = {
            mavlink2.MAV_CMD_DO_SET_MODE: self._set_mode,
            mavlink2.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            mavlink2.MAV_CMD_NAV_TAKEOFF: self._takeoff,
            mavlink2.MAV_CMD_NAV_LAND: self._land,
            mavlink2.MAV_CMD_DO_REPOSITION: self._reposition,
            mavlink2.MAV_CMD_DO_CHANGE_SPEED: self._change_speed,
            mavlink2.MAV_CMD_DO_SET_HOME: self._set_home,
            mavlink2.MAV_CMD_DO_FLIGHTTERMINATION: self._terminate,
            mavlink2.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._reboot,
            mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL: self._set_message_interval,
            mavlink2.MAV_CMD_GET_MESSAGE_INTERVAL: self._get_message_interval,
            mavlink2.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._request_autopilot_version,
            mavlink2.MAV_CMD_GET_HOME_POSITION: self._request_home,
            mavlink2.MAV_CMD_DO_SET_MISSION_CURRENT: self._set_mission_current,
            mavlink2.MAV_CMD_INJECT_FAILURE: self._inject_failure,
        }

    def handle(self, request: CommandRequest) -> CommandReply:
        """Execute ``request`` (or recognise a retransmission) and return the ACK result."""
        now_s = self._wall_clock_s()
        identity = request.identity()
        previous = self._last_by_source.get(request.source)
        if (
            request.command not in _REQUESTS
            and previous is not None
            and previous.identity == identity
            and now_s - previous.wall_time_s <= DUPLICATE_WINDOW_S
            and previous.state == self._state()
        ):
            return CommandReply(previous.result, duplicate=True)
        result = self._execute(request)
        if result == ACCEPTED:
            self._last_by_source[request.source] = _Handled(identity, result, now_s, self._state())
        else:
            # A refusal has no side effect: a repeat is executed again, since the vehicle may
            # have become ready in between (a mission uploaded, a position fix).
            self._last_by_source.pop(request.source, None)
        return CommandReply(result, duplicate=False)

    def _state(self) -> tuple[bool, int, int]:
        snap = self._vehicle.telemetry()
        return (snap.armed, snap.main_mode, snap.sub_mode)

    def _execute(self, request: CommandRequest) -> int:
        handler = self._handlers.get(request.command)
        if handler is None:
            return UNSUPPORTED
        try:
            return handler(request)
        except _Rejected as rejection:
            logger.info("command %d rejected: %s", request.command, rejection)
            return rejection.result
        except Exception:
            logger.exception("command %d failed", request.command)
            return FAILED

    # --- position helpers --------------------------------------------------------------------

    def _lat_lon_deg(self, request: CommandRequest) -> tuple[float, float]:
        """Target latitude/longitude in degrees, NaN where the sender left them unset."""
        if request.frame is None:
            return _optional(request.x, "latitude"), _optional(request.y, "longitude")
        self._check_global_frame(request.frame)
        lat = math.nan if request.x == _INT32_MAX else request.x / 1e7
        lon = math.nan if request.y == _INT32_MAX else request.y / 1e7
        return lat, lon

    def _alt_amsl_m(self, request: CommandRequest) -> float:
        """Target altitude AMSL in metres (NaN = unset); relative frames add the home altitude."""
        alt = _optional(request.z, "altitude")
        if request.frame is None or math.isnan(alt):
            return alt
        self._check_global_frame(request.frame)
        if request.frame in _RELATIVE_FRAMES:
            home_alt = self._services.home_alt_amsl_m()
            if home_alt is None:
                raise _Rejected(DENIED, "relative altitude needs a home position")
            return alt + home_alt
        return alt

    @staticmethod
    def _check_global_frame(frame: int) -> None:
        if frame not in _AMSL_FRAMES and frame not in _RELATIVE_FRAMES:
            raise _Rejected(DENIED, f"unsupported frame {frame}")

    # --- vehicle commands --------------------------------------------------------------------

    def _set_mode(self, request: CommandRequest) -> int:
        base = int(_required(request.params[0], "base mode"))
        if not base & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            raise _Rejected(DENIED, "only PX4 custom modes are supported")
        main_mode = round(_required(request.params[1], "main mode"))
        sub = request.params[2]
        sub_mode = round(sub) if _finite(sub) else 0
        if not 0 < main_mode < 256 or not 0 <= sub_mode < 256:
            raise _Rejected(DENIED, f"mode {main_mode}/{sub_mode} out of range")
        return self._vehicle.set_mode(main_mode, sub_mode)

    def _arm_disarm(self, request: CommandRequest) -> int:
        action = round(_required(request.params[0], "arm flag"))
        force = request.params[1] == FORCE_MAGIC
        if action == 1:
            return self._vehicle.arm(force)
        if action == 0:
            return self._vehicle.disarm(force)
        raise _Rejected(DENIED, f"param1 must be 0 or 1, got {request.params[0]}")

    def _takeoff(self, request: CommandRequest) -> int:
        alt = self._alt_amsl_m(request)
        return self._vehicle.takeoff(None if math.isnan(alt) else alt)

    def _land(self, request: CommandRequest) -> int:
        return self._vehicle.land()

    def _reposition(self, request: CommandRequest) -> int:
        speed = _optional(request.params[0], "speed")
        if speed < 0.0:
            speed = math.nan
        yaw = _optional(request.params[3], "yaw")
        lat, lon = self._lat_lon_deg(request)
        alt = self._alt_amsl_m(request)
        return self._vehicle.reposition(lat, lon, alt, yaw, speed)

    def _change_speed(self, request: CommandRequest) -> int:
        return self._vehicle.change_speed(_optional(request.params[1], "speed"))

    def _set_home(self, request: CommandRequest) -> int:
        use_current = round(_required(request.params[0], "use-current flag")) == 1
        if use_current:
            return self._vehicle.set_home(True, math.nan, math.nan, math.nan)
        lat, lon = self._lat_lon_deg(request)
        alt = self._alt_amsl_m(request)
        for value, what in ((lat, "latitude"), (lon, "longitude"), (alt, "altitude")):
            _required(value, what)
        return self._vehicle.set_home(False, lat, lon, alt)

    def _terminate(self, request: CommandRequest) -> int:
        if _required(request.params[0], "terminate flag") >= 0.5:
            return self._vehicle.terminate()
        return ACCEPTED

    def _reboot(self, request: CommandRequest) -> int:
        action = round(_required(request.params[0], "autopilot action"))
        if action != 0:
            verb = {1: "reboot", 2: "shutdown", 3: "reboot to bootloader"}.get(action, "action")
            self._services.announce(
                mavlink2.MAV_SEVERITY_WARNING, f"Autopilot {verb} requested: ignored in simulation"
            )
        return ACCEPTED

    def _set_mission_current(self, request: CommandRequest) -> int:
        seq = _required(request.params[0], "mission item")
        if seq != int(seq) or not self._vehicle.set_mission_current(int(seq)):
            raise _Rejected(DENIED, f"mission item {seq} does not exist")
        return ACCEPTED

    def _inject_failure(self, request: CommandRequest) -> int:
        unit = _required(request.params[0], "failure unit")
        kind = _required(request.params[1], "failure type")
        instance = request.params[2] if _finite(request.params[2]) else 0.0
        if not all(v == int(v) and 0 <= v <= 255 for v in (unit, kind, instance)):
            raise _Rejected(DENIED, "failure unit, type and instance must be small integers")
        return self._vehicle.inject_failure(int(unit), int(kind), int(instance))

    # --- endpoint commands -------------------------------------------------------------------

    @staticmethod
    def _message_id(value: float) -> int:
        msg_id = round(_required(value, "message id"))
        if not 0 <= msg_id <= 0xFFFFFF:
            raise _Rejected(DENIED, f"message id {msg_id} out of range")
        return msg_id

    def _set_message_interval(self, request: CommandRequest) -> int:
        msg_id = self._message_id(request.params[0])
        interval_us = round(_required(request.params[1], "interval"))
        return self._services.set_message_interval(msg_id, interval_us)

    def _get_message_interval(self, request: CommandRequest) -> int:
        return self._services.report_message_interval(self._message_id(request.params[0]))

    def _request_message(self, request: CommandRequest) -> int:
        return self._services.request_message(self._message_id(request.params[0]))

    def _request_autopilot_version(self, request: CommandRequest) -> int:
        return self._services.request_message(mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION)

    def _request_home(self, request: CommandRequest) -> int:
        return self._services.request_message(mavlink2.MAVLINK_MSG_ID_HOME_POSITION)
