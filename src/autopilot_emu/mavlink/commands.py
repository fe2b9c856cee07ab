"""MAVLink command protocol: COMMAND_LONG / COMMAND_INT -> vehicle call -> MAV_RESULT.

:class:`CommandRequest` normalises both messages. :class:`CommandDispatcher` validates the
parameters, calls the vehicle or the endpoint services, and turns exceptions into FAILED so every
command is answered. A parameter outside its MAVLink range (a NaN or infinity where a number is
required, a latitude beyond +-90 deg, an arm flag other than 0/1, an unknown PX4 mode, a message
id that does not fit the field it is reported in, ...) is answered with DENIED before the vehicle
sees the command. The checks follow PX4 (``src/modules/mavlink/mavlink_receiver.cpp``,
``src/modules/commander/Commander.cpp``, ``src/modules/navigator/navigator_main.cpp``); where
PX4 accepts an out-of-range value and computes garbage with it (e.g. DO_SET_HOME latitude 1000),
the emulator denies it instead. docs/autopilot.md lists the rules per command. Retransmissions
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
from autopilot_emu.modes import AutoSubMode, MainMode

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
_INT32_MIN = -(2**31)
_COMMAND_INT_NAN = 0x7FF80000
"""COMMAND_INT x and y both equal to this: a float NaN sent as int (PX4 denies the command)."""
_FLOAT32_INT32_MAX = (math.nextafter(2.0**31, 0.0), math.nextafter(2.0**31, math.inf))
"""float(INT32_MAX) rounded to float32 and its neighbours: param5/param6 of a COMMAND_LONG in
this range look like COMMAND_INT's "unset" sent in the wrong message (PX4 denies the command)."""
MAX_LATITUDE_DEG = 90.0
MAX_LONGITUDE_DEG = 180.0
MAX_MESSAGE_ID = 0xFFFFFF
"""MAVLink 2 message ids are 24-bit."""
MAX_STREAMED_MESSAGE_ID = 0xFFFF
"""MESSAGE_INTERVAL.message_id is uint16: SET/GET_MESSAGE_INTERVAL only address ids up to this."""
_MAIN_MODES = frozenset(int(m) for m in MainMode)
_AUTO_SUB_MODES = frozenset(int(m) for m in AutoSubMode)
_SPEED_TYPES = frozenset(
    {
        mavlink2.SPEED_TYPE_AIRSPEED,
        mavlink2.SPEED_TYPE_GROUNDSPEED,
        mavlink2.SPEED_TYPE_CLIMB_SPEED,
        mavlink2.SPEED_TYPE_DESCENT_SPEED,
    }
)
_SPEED_KEEP_OR_DEFAULT = (-1.0, -2.0)
"""DO_CHANGE_SPEED speed/throttle -1 "no change" and -2 "back to default" (PX4: both default)."""
_REPOSITION_FLAGS = (
    mavlink2.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE | mavlink2.MAV_DO_REPOSITION_FLAGS_RELATIVE_YAW
)
_REBOOT_ACTIONS = {1: "reboot", 2: "shutdown", 3: "reboot to bootloader"}
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
    """What the dispatcher needs from its link (messages and streams): the link's CommandHandler."""

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


def _choice(value: float, allowed: frozenset[int] | range, what: str) -> int:
    """``value`` rounded to the nearest integer if that is one of ``allowed``, else DENIED."""
    number = round(_required(value, what))
    if number not in allowed:
        raise _Rejected(DENIED, f"{what} {value} is not one of the allowed values")
    return number


def _zero_or_unset(value: float, what: str) -> None:
    """DENIED unless ``value`` is NaN or rounds to 0 (a PX4 "not supported" option)."""
    if not math.isnan(value) and (math.isinf(value) or round(value) != 0):
        raise _Rejected(DENIED, f"{what} {value} is not supported")


def _check_lat_lon(lat: float, lon: float) -> None:
    """DENIED if a given (non-NaN) latitude or longitude is outside the WGS-84 ranges."""
    if abs(lat) > MAX_LATITUDE_DEG:
        raise _Rejected(DENIED, f"latitude {lat} outside [-90, 90] deg")
    if abs(lon) > MAX_LONGITUDE_DEG:
        raise _Rejected(DENIED, f"longitude {lon} outside [-180, 180] deg")


def _malformed(request: CommandRequest) -> str | None:
    """Why PX4's receiver denies ``request`` before looking at the command, or None.

    mavlink_receiver.cpp handle_message_command_long: param5 and param6 both INT32_MAX as
    float (COMMAND_INT's "unset" sent in a COMMAND_LONG); handle_message_command_int: x and y
    both 0x7ff80000 (a float NaN sent as an int).
    """
    if request.frame is None:
        low, high = _FLOAT32_INT32_MAX
        if low <= request.x <= high and low <= request.y <= high:
            return "param5/param6 look like INT32_MAX"
    elif request.x == _COMMAND_INT_NAN and request.y == _COMMAND_INT_NAN:
        return "x/y look like a NaN sent as int"
    return None


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
            mavlink2.MAV_CMD_MISSION_START: self._mission_start,
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
        malformed = _malformed(request)
        if malformed is not None:
            logger.info("command %d denied: %s", request.command, malformed)
            return DENIED
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
        """Target latitude/longitude in degrees, NaN where the sender left them unset.

        COMMAND_INT leaves the position unset with x = y = INT32_MAX (both, as PX4 reads it);
        a given latitude or longitude outside the WGS-84 range is DENIED.
        """
        if request.frame is None:
            lat, lon = _optional(request.x, "latitude"), _optional(request.y, "longitude")
        else:
            self._check_global_frame(request.frame)
            if request.x == _INT32_MAX and request.y == _INT32_MAX:
                return math.nan, math.nan
            lat, lon = request.x / 1e7, request.y / 1e7
        _check_lat_lon(lat, lon)
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
        """DO_SET_MODE: base mode (uint8) with CUSTOM_MODE_ENABLED, a PX4 main mode, a sub mode.

        PX4 (Commander.cpp) casts the params to uint8 and ignores unknown main modes; here a
        main mode outside px4_custom_mode.h's table, or an AUTO sub mode outside it, is DENIED.
        The sub mode of a non-AUTO mode is ignored by PX4; it must still fit its uint8 byte.
        """
        base = _choice(request.params[0], range(256), "base mode")
        if not base & mavlink2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            raise _Rejected(DENIED, "only PX4 custom modes are supported")
        main_mode = _choice(request.params[1], _MAIN_MODES, "main mode")
        sub = request.params[2]
        sub_modes = _AUTO_SUB_MODES if main_mode == MainMode.AUTO else range(256)
        sub_mode = 0 if math.isnan(sub) else _choice(sub, sub_modes, "sub mode")
        return self._vehicle.set_mode(main_mode, sub_mode)

    def _arm_disarm(self, request: CommandRequest) -> int:
        """ARM_DISARM: param1 rounds to 0 or 1; param2 rounding to 21196 forces (as PX4)."""
        action = _choice(request.params[0], range(2), "arm flag")
        force = _finite(request.params[1]) and round(request.params[1]) == FORCE_MAGIC
        if action == 1:
            return self._vehicle.arm(force)
        return self._vehicle.disarm(force)

    def _check_yaw(self, request: CommandRequest) -> float:
        """param4 yaw: finite or NaN (keep the current heading)."""
        return _optional(request.params[3], "yaw")

    def _takeoff(self, request: CommandRequest) -> int:
        """NAV_TAKEOFF: yaw, lat/lon (in range or unset) and altitude checked; takes off here."""
        self._check_yaw(request)
        self._lat_lon_deg(request)
        alt = self._alt_amsl_m(request)
        return self._vehicle.takeoff(None if math.isnan(alt) else alt)

    def _land(self, request: CommandRequest) -> int:
        """NAV_LAND: yaw, lat/lon (in range or unset) and altitude checked; lands here."""
        self._check_yaw(request)
        self._lat_lon_deg(request)
        _optional(request.z, "altitude")
        return self._vehicle.land()

    def _reposition(self, request: CommandRequest) -> int:
        """DO_REPOSITION: speed (< 0: default), MAV_DO_REPOSITION_FLAGS, yaw, position."""
        speed = _optional(request.params[0], "speed")
        if speed < 0.0:
            speed = math.nan
        flags = request.params[1]
        if not math.isnan(flags):
            _choice(flags, range(_REPOSITION_FLAGS + 1), "reposition flags")
        yaw = self._check_yaw(request)
        lat, lon = self._lat_lon_deg(request)
        alt = self._alt_amsl_m(request)
        return self._vehicle.reposition(lat, lon, alt, yaw, speed)

    def _change_speed(self, request: CommandRequest) -> int:
        """DO_CHANGE_SPEED: SPEED_TYPE, speed >= 0 / -1 / -2 / NaN, throttle 0..100 / -1 / -2.

        PX4's multicopter navigator applies the speed whatever its type ("not differentiating
        ground and airspeed yet") and treats a speed <= 0 as "back to the default".
        """
        _choice(request.params[0], _SPEED_TYPES, "speed type")
        speed = _optional(request.params[1], "speed")
        if speed < 0.0 and speed not in _SPEED_KEEP_OR_DEFAULT:
            raise _Rejected(DENIED, f"speed {speed} is negative")
        throttle = _optional(request.params[2], "throttle")
        if not (
            math.isnan(throttle) or throttle in _SPEED_KEEP_OR_DEFAULT or 0.0 <= throttle <= 100.0
        ):
            raise _Rejected(DENIED, f"throttle {throttle} outside 0..100 %")
        return self._vehicle.change_speed(speed)

    def _set_home(self, request: CommandRequest) -> int:
        """DO_SET_HOME: param1 0/1; a given home needs lat/lon in range and a finite altitude."""
        use_current = _choice(request.params[0], range(2), "use-current flag") == 1
        if use_current:
            return self._vehicle.set_home(True, math.nan, math.nan, math.nan)
        self._check_yaw(request)
        lat, lon = self._lat_lon_deg(request)
        alt = self._alt_amsl_m(request)
        for value, what in ((lat, "latitude"), (lon, "longitude"), (alt, "altitude")):
            _required(value, what)
        return self._vehicle.set_home(False, lat, lon, alt)

    def _terminate(self, request: CommandRequest) -> int:
        """DO_FLIGHTTERMINATION: param1 > 0.5 terminates; anything else is DENIED (as PX4)."""
        if _required(request.params[0], "terminate flag") > 0.5:
            return self._vehicle.terminate()
        raise _Rejected(DENIED, "flight termination not requested (param1 <= 0.5)")

    def _reboot(self, request: CommandRequest) -> int:
        """PREFLIGHT_REBOOT_SHUTDOWN: param1 0..3; 1..3 are DENIED while armed (as PX4)."""
        action = _choice(request.params[0], range(4), "autopilot action")
        if action == 0:
            return ACCEPTED
        if self._vehicle.telemetry().armed:
            raise _Rejected(DENIED, "reboot/shutdown while armed")
        self._services.announce(
            mavlink2.MAV_SEVERITY_WARNING,
            f"Autopilot {_REBOOT_ACTIONS[action]} requested: ignored in simulation",
        )
        return ACCEPTED

    def _set_mission_current(self, request: CommandRequest) -> int:
        seq = _required(request.params[0], "mission item")
        if seq != int(seq) or not self._vehicle.set_mission_current(int(seq)):
            raise _Rejected(DENIED, f"mission item {seq} does not exist")
        return ACCEPTED

    def _mission_start(self, request: CommandRequest) -> int:
        first = request.params[0]
        if math.isnan(first):
            first = -1.0  # MAVSDK-style "unset": continue at the current item
        if not (math.isfinite(first) and first == int(first) and first >= -1):
            raise _Rejected(DENIED, f"first mission item {first} is not an item index or -1")
        return self._vehicle.start_mission(int(first))

    def _inject_failure(self, request: CommandRequest) -> int:
        unit = _required(request.params[0], "failure unit")
        kind = _required(request.params[1], "failure type")
        instance = request.params[2] if _finite(request.params[2]) else 0.0
        if not all(v == int(v) and 0 <= v <= 255 for v in (unit, kind, instance)):
            raise _Rejected(DENIED, "failure unit, type and instance must be small integers")
        return self._vehicle.inject_failure(int(unit), int(kind), int(instance))

    # --- endpoint commands -------------------------------------------------------------------

    @staticmethod
    def _message_id(value: float, highest: int = MAX_MESSAGE_ID) -> int:
        msg_id = round(_required(value, "message id"))
        if not 0 <= msg_id <= highest:
            raise _Rejected(DENIED, f"message id {msg_id} out of range 0..{highest}")
        return msg_id

    def _set_message_interval(self, request: CommandRequest) -> int:
        """SET_MESSAGE_INTERVAL as PX4's MavlinkReceiver::set_message_interval reads it.

        HEARTBEAT's rate cannot be changed; req_param3/4 and the response target (param7) are
        not supported unless NaN or 0. The interval must be finite and fit the int32 interval_us
        of MESSAGE_INTERVAL: |interval| <= 1e-5 us means the default rate, any negative one
        stops the stream, a positive one is rounded to whole microseconds (at least 1; the
        stream table then caps the rate at streams.MAX_STREAM_RATE_HZ).
        """
        msg_id = self._message_id(request.params[0], MAX_STREAMED_MESSAGE_ID)
        if msg_id == mavlink2.MAVLINK_MSG_ID_HEARTBEAT:
            raise _Rejected(DENIED, "the HEARTBEAT rate cannot be changed")
        interval = _required(request.params[1], "interval")
        if not _INT32_MIN <= interval <= _INT32_MAX:
            raise _Rejected(DENIED, f"interval {interval} us does not fit an int32")
        _zero_or_unset(request.params[2], "req_param3")
        _zero_or_unset(request.params[3], "req_param4")
        _zero_or_unset(request.z, "response target")
        if abs(interval) <= 1e-5:
            interval_us = 0
        elif interval < 0.0:
            interval_us = -1
        else:
            interval_us = max(1, round(interval))
        return self._services.set_message_interval(msg_id, interval_us)

    def _get_message_interval(self, request: CommandRequest) -> int:
        msg_id = self._message_id(request.params[0], MAX_STREAMED_MESSAGE_ID)
        return self._services.report_message_interval(msg_id)

    def _request_message(self, request: CommandRequest) -> int:
        return self._services.request_message(self._message_id(request.params[0]))

    def _request_autopilot_version(self, request: CommandRequest) -> int:
        return self._services.request_message(mavlink2.MAVLINK_MSG_ID_AUTOPILOT_VERSION)

    def _request_home(self, request: CommandRequest) -> int:
        return self._services.request_message(mavlink2.MAVLINK_MSG_ID_HOME_POSITION)
