"""Telemetry stream profiles (PX4's MAVLink modes) and a simulation-time scheduler for them.

PX4 runs one MAVLink instance per link, each in a mode whose default stream rates come from
``Mavlink::configure_streams_to_default`` (src/modules/mavlink/mavlink_main.cpp). PX4 SITL starts
the ground-station link in the *normal* mode and the offboard/API link in the *onboard* mode
(ROMFS/px4fmu_common/init.d-posix/px4-rc.mavlink). :data:`PROFILES` holds both tables as data,
restricted to the messages this emulator can fill, with PX4's rates (Hz) and order; HEARTBEAT
(``Mavlink::task_main``) and MISSION_CURRENT (the mission manager, once a second) go out on every
link. Every other message with a builder can still be switched on at run time
(MAV_CMD_SET_MESSAGE_INTERVAL) or by configuration, as PX4 allows any stream on any link.

Intervals are kept in integer microseconds of simulation time, so a run emits exactly the same
messages at the same instants whatever the wall clock does.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

from pymavlink.dialects.v20 import common as mavlink2

INTERVAL_DEFAULT = 0
"""SET_MESSAGE_INTERVAL interval_us meaning "back to the default rate"."""
INTERVAL_DISABLED = -1
"""SET_MESSAGE_INTERVAL interval_us meaning "stop this stream"."""
MAX_STREAM_RATE_HZ = 100.0
"""Fastest rate a SET_MESSAGE_INTERVAL request can give a stream, Hz of simulation time.

PX4 never sends a stream faster than its MAVLink loop runs, whatever the request: it accepts the
interval and each stream goes out at most once per loop iteration (mavlink_main.cpp). Its fastest
default stream is ATTITUDE at 100 Hz in the onboard profile (configure_streams_to_default,
MAVLINK_MODE_ONBOARD), the profile the companion link uses. The endpoint's loop is the
simulation's MAVLink poll (250 Hz by default, SimulationConfig.mavlink_poll_hz), so 100 Hz is
both what PX4 serves a companion at most and safely below the poll rate: shorter intervals are
accepted and clamped to :data:`MIN_INTERVAL_US`, as PX4 effectively does."""
MIN_INTERVAL_US = round(1e6 / MAX_STREAM_RATE_HZ)
"""Shortest interval a SET_MESSAGE_INTERVAL request can set, microseconds."""
UNLIMITED = -1.0
"""PX4's ``unlimited_rate``: the message goes out whenever its source has new data. Here the
source's update rate stands in for it (GPS_RAW_INT: the GPS receiver's rate)."""
_NEVER_US = 2**63 - 1


class StreamProfile(StrEnum):
    """PX4 MAVLink mode of a link (``mavlink start -m``): which streams it sends by default."""

    NORMAL = "normal"
    """Ground-station link (QGroundControl, MAVProxy): PX4 SITL's port 18570+i -> 14550."""
    ONBOARD = "onboard"
    """Companion / offboard-API link (MAVSDK, MAVROS): PX4 SITL's port 14580+i -> 14540+i."""


EVERY_LINK: dict[str, float] = {"HEARTBEAT": 1.0, "MISSION_CURRENT": 1.0}
"""Streams of every link whatever its mode, Hz: HEARTBEAT (task_main), MISSION_CURRENT (the
mission manager's 1 s rate limiter)."""

PROFILES: dict[StreamProfile, dict[str, float]] = {
    StreamProfile.NORMAL: {
        "ALTITUDE": 1.0,
        "ATTITUDE": 15.0,
        "ATTITUDE_QUATERNION": 10.0,
        "ATTITUDE_TARGET": 2.0,
        "BATTERY_STATUS": 0.5,
        "ESTIMATOR_STATUS": 0.5,
        "EXTENDED_SYS_STATE": 1.0,
        "GLOBAL_POSITION_INT": 5.0,
        "GPS_GLOBAL_ORIGIN": 1.0,
        "GPS_RAW_INT": 5.0,
        "HOME_POSITION": 0.5,
        "LOCAL_POSITION_NED": 1.0,
        "POSITION_TARGET_GLOBAL_INT": 1.0,
        "POSITION_TARGET_LOCAL_NED": 1.5,
        "SYS_STATUS": 1.0,
        "VFR_HUD": 4.0,
        "DISTANCE_SENSOR": UNLIMITED,
    },
    StreamProfile.ONBOARD: {
        "TIMESYNC": 10.0,
        "HIGHRES_IMU": 50.0,
        "LOCAL_POSITION_NED": 30.0,
        "ATTITUDE": 100.0,
        "ALTITUDE": 10.0,
        "ODOMETRY": 30.0,
        "ATTITUDE_QUATERNION": 50.0,
        "ATTITUDE_TARGET": 10.0,
        "BATTERY_STATUS": 0.5,
        "ESTIMATOR_STATUS": 1.0,
        "EXTENDED_SYS_STATE": 5.0,
        "GLOBAL_POSITION_INT": 50.0,
        "GPS_GLOBAL_ORIGIN": 1.0,
        "GPS_RAW_INT": UNLIMITED,
        "HOME_POSITION": 0.5,
        "POSITION_TARGET_GLOBAL_INT": 10.0,
        "POSITION_TARGET_LOCAL_NED": 10.0,
        "SYS_STATUS": 5.0,
        "SYSTEM_TIME": 1.0,
        "VFR_HUD": 10.0,
        "DISTANCE_SENSOR": UNLIMITED,
    },
}
"""PX4's default rates per mode, Hz, for the messages the emulator fills (PX4 order: the
low-latency streams first); :data:`UNLIMITED` = on every update of the source.

DISTANCE_SENSOR departs from PX4 (0.5 Hz in the normal mode, 10 Hz onboard, in
configure_streams_to_default): here every new reading of every range finder goes out on both
links, at the sensors' rate, so that a ground station and the companion both see each sensor as
it reads (issue 8); SET_MESSAGE_INTERVAL can slow it down or stop it per link."""

ON_REQUEST: tuple[str, ...] = ("FLIGHT_INFORMATION",)
"""Off in every profile until a client asks (MAVSDK's info.flight_information() sets
FLIGHT_INFORMATION to 1 Hz with SET_MESSAGE_INTERVAL), as in PX4."""

STREAMABLE: tuple[str, ...] = tuple(
    dict.fromkeys(
        [
            *EVERY_LINK,
            *PROFILES[StreamProfile.ONBOARD],
            *PROFILES[StreamProfile.NORMAL],
            *ON_REQUEST,
        ]
    )
)
"""Every message a link can stream (off unless its profile, the configuration or
SET_MESSAGE_INTERVAL switches it on), in the order they go out when due together."""


@dataclass(frozen=True)
class StreamSpec:
    """One periodic message and its default rate."""

    name: str
    """MAVLink message name (key of EndpointConfig.stream_rates_hz)."""
    msg_id: int
    """MAVLink message id."""
    default_rate_hz: float
    """Rate in simulation time, Hz (0 = off by default)."""


def profile_streams(
    profile: StreamProfile, unlimited_rate_hz: float, distance_sensor_rate_hz: float = 0.0
) -> tuple[StreamSpec, ...]:
    """Every streamable message with its default rate in ``profile`` (0 = off).

    Args:
        profile: the link's PX4 mode.
        unlimited_rate_hz: rate that stands in for PX4's unlimited rate, Hz (the rate at which
            the source has new data, e.g. the GPS receiver's).
        distance_sensor_rate_hz: rate of the fastest range finder, Hz, the DISTANCE_SENSOR
            stream's (0: the vehicle has none, the stream is off).
    """
    rates = {**EVERY_LINK, **PROFILES[profile]}
    specs = []
    for name in STREAMABLE:
        rate = rates.get(name, 0.0)
        if rate == UNLIMITED:
            rate = distance_sensor_rate_hz if name == "DISTANCE_SENSOR" else unlimited_rate_hz
        specs.append(StreamSpec(name, getattr(mavlink2, f"MAVLINK_MSG_ID_{name}"), rate))
    return tuple(specs)


def rate_to_interval_us(rate_hz: float) -> int:
    """Stream rate -> interval in microseconds; 0 Hz or less -> disabled (-1)."""
    if not rate_hz > 0.0:
        return INTERVAL_DISABLED
    return max(1, round(1e6 / rate_hz))


CONST_RATE_STREAMS: frozenset[str] = frozenset({"HEARTBEAT"})
"""Streams a link's rate multiplier never scales (PX4: ``MavlinkStream::const_rate()``)."""

MIN_RATE_MULT = 0.0005
"""Smallest rate multiplier: even a saturated link sends every stream now and then."""


@dataclass
class _Stream:
    spec: StreamSpec
    default_interval_us: int
    interval_us: int
    """The configured interval (what MESSAGE_INTERVAL reports)."""
    next_due_us: int
    sent_interval_us: int = 0
    """The interval actually used: ``interval_us`` / the link's rate multiplier."""

    def __post_init__(self) -> None:
        self.sent_interval_us = self.interval_us


class StreamScheduler:
    """Which streams are due at a given simulation time.

    Args:
        specs: the stream table.
        rates_hz: per-name overrides of the default rates (0 disables a stream).

    Raises:
        ValueError: an override names a stream that is not in ``specs``.
    """

    def __init__(
        self,
        specs: tuple[StreamSpec, ...],
        rates_hz: Mapping[str, float] | None = None,
    ) -> None:
        rates_hz = rates_hz or {}
        names = {spec.name for spec in specs}
        unknown = sorted(set(rates_hz) - names)
        if unknown:
            raise ValueError(f"unknown streams {unknown}; known: {sorted(names)}")
        self._streams: list[_Stream] = []
        self._by_id: dict[int, _Stream] = {}
        self.rate_mult = 1.0
        """Multiplier of every non-constant stream's rate (PX4's ``_rate_mult``), 0..1."""
        for spec in specs:
            interval = rate_to_interval_us(rates_hz.get(spec.name, spec.default_rate_hz))
            stream = _Stream(spec, interval, interval, 0 if interval > 0 else _NEVER_US)
            self._streams.append(stream)
            self._by_id[spec.msg_id] = stream
        self.next_due_us = self._earliest()

    def _earliest(self) -> int:
        return min((s.next_due_us for s in self._streams), default=_NEVER_US)

    def knows(self, msg_id: int) -> bool:
        """Whether ``msg_id`` is one of the streams."""
        return msg_id in self._by_id

    def interval_us(self, msg_id: int) -> int:
        """Current interval of ``msg_id`` (-1 disabled); KeyError if not a stream."""
        return self._by_id[msg_id].interval_us

    def set_interval(self, msg_id: int, interval_us: int, now_us: int) -> bool:
        """Apply SET_MESSAGE_INTERVAL semantics (0 default, -1 stop, > 0 interval).

        A positive interval shorter than :data:`MIN_INTERVAL_US` is clamped to it.

        Returns:
            False if ``msg_id`` is not a stream or ``interval_us`` is below -1.
        """
        stream = self._by_id.get(msg_id)
        if stream is None or interval_us < INTERVAL_DISABLED:
            return False
        if interval_us == INTERVAL_DEFAULT:
            interval_us = stream.default_interval_us
        elif interval_us > 0:
            interval_us = max(interval_us, MIN_INTERVAL_US)
        stream.interval_us = interval_us
        stream.sent_interval_us = self._scaled(stream)
        stream.next_due_us = now_us + stream.sent_interval_us if interval_us > 0 else _NEVER_US
        self.next_due_us = self._earliest()
        return True

    def _scaled(self, stream: _Stream) -> int:
        if stream.interval_us <= 0 or stream.spec.name in CONST_RATE_STREAMS:
            return stream.interval_us
        return max(1, round(stream.interval_us / self.rate_mult))

    def bytes_per_s(self, frame_bytes: Mapping[int, float]) -> tuple[float, float]:
        """Load of the configured streams, B/s: (constant-rate streams, the others).

        ``frame_bytes`` gives the bytes one emission of each stream takes (an average of what
        was sent, or an estimate); streams it does not name count as 0.
        """
        const = scaled = 0.0
        for stream in self._streams:
            if stream.interval_us > 0:
                load = frame_bytes.get(stream.spec.msg_id, 0.0) * 1e6 / stream.interval_us
                if stream.spec.name in CONST_RATE_STREAMS:
                    const += load
                else:
                    scaled += load
        return const, scaled

    def set_rate_mult(self, rate_mult: float, now_us: int) -> None:
        """Scale every non-constant stream's rate by ``rate_mult`` (clamped to MIN_RATE_MULT..1).

        PX4 (``Mavlink::update_rate_mult``) does this on a link with a data-rate limit so its
        streams fit: ``min(1, (datarate - constant streams' load) / other streams' load)``.
        """
        rate_mult = min(1.0, max(MIN_RATE_MULT, float(rate_mult)))
        if rate_mult == self.rate_mult:
            return
        self.rate_mult = rate_mult
        for stream in self._streams:
            new = self._scaled(stream)
            if new != stream.sent_interval_us and stream.interval_us > 0:
                stream.next_due_us = min(stream.next_due_us, now_us + new)
            stream.sent_interval_us = new
        self.next_due_us = self._earliest()

    def pop_due(self, now_us: int) -> list[StreamSpec]:
        """Streams due at ``now_us``, rescheduled one interval later (no catch-up bursts)."""
        if now_us < self.next_due_us:
            return []
        due: list[StreamSpec] = []
        earliest = _NEVER_US
        for stream in self._streams:
            next_due = stream.next_due_us
            if next_due <= now_us:
                due.append(stream.spec)
                next_due += stream.sent_interval_us
                if next_due <= now_us:
                    next_due = now_us + stream.sent_interval_us
                stream.next_due_us = next_due
            if next_due < earliest:
                earliest = next_due
        self.next_due_us = earliest
        return due

    def restart(self, now_us: int) -> None:
        """Make every enabled stream due at ``now_us`` (after the clock went backwards)."""
        for stream in self._streams:
            if stream.interval_us > 0:
                stream.next_due_us = now_us
        self.next_due_us = self._earliest()
