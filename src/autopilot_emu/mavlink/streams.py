"""Telemetry stream table and a simulation-time scheduler for it.

The defaults approximate PX4 SITL's onboard profile (MAVSDK_CONTRACT.md section 5). Intervals are
kept in integer microseconds of simulation time, so a run emits exactly the same messages at the
same instants whatever the wall clock does. MAV_CMD_SET_MESSAGE_INTERVAL edits the table at run
time (:meth:`StreamScheduler.set_interval`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

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
_NEVER_US = 2**63 - 1


@dataclass(frozen=True)
class StreamSpec:
    """One periodic message and its default rate."""

    name: str
    """MAVLink message name (key of EndpointConfig.stream_rates_hz)."""
    msg_id: int
    """MAVLink message id."""
    default_rate_hz: float
    """Rate in simulation time, Hz (0 = off by default)."""


DEFAULT_STREAMS: tuple[StreamSpec, ...] = (
    StreamSpec("HEARTBEAT", mavlink2.MAVLINK_MSG_ID_HEARTBEAT, 1.0),
    StreamSpec("SYS_STATUS", mavlink2.MAVLINK_MSG_ID_SYS_STATUS, 2.0),
    StreamSpec("EXTENDED_SYS_STATE", mavlink2.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 2.0),
    StreamSpec("GLOBAL_POSITION_INT", mavlink2.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 20.0),
    StreamSpec("LOCAL_POSITION_NED", mavlink2.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 20.0),
    StreamSpec("ATTITUDE", mavlink2.MAVLINK_MSG_ID_ATTITUDE, 20.0),
    StreamSpec("ATTITUDE_QUATERNION", mavlink2.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, 20.0),
    StreamSpec("GPS_RAW_INT", mavlink2.MAVLINK_MSG_ID_GPS_RAW_INT, 5.0),
    StreamSpec("BATTERY_STATUS", mavlink2.MAVLINK_MSG_ID_BATTERY_STATUS, 1.0),
    StreamSpec("HOME_POSITION", mavlink2.MAVLINK_MSG_ID_HOME_POSITION, 0.5),
    StreamSpec("VFR_HUD", mavlink2.MAVLINK_MSG_ID_VFR_HUD, 4.0),
    StreamSpec("ALTITUDE", mavlink2.MAVLINK_MSG_ID_ALTITUDE, 5.0),
    StreamSpec("SYSTEM_TIME", mavlink2.MAVLINK_MSG_ID_SYSTEM_TIME, 1.0),
    StreamSpec("MISSION_CURRENT", mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT, 1.0),
    # Off until asked for, as PX4: MAVSDK's info.flight_information() sets it to 1 Hz.
    StreamSpec("FLIGHT_INFORMATION", mavlink2.MAVLINK_MSG_ID_FLIGHT_INFORMATION, 0.0),
)
"""Streams sent unprompted, in the order they go out when due together."""


def rate_to_interval_us(rate_hz: float) -> int:
    """Stream rate -> interval in microseconds; 0 Hz or less -> disabled (-1)."""
    if not rate_hz > 0.0:
        return INTERVAL_DISABLED
    return max(1, round(1e6 / rate_hz))


@dataclass
class _Stream:
    spec: StreamSpec
    default_interval_us: int
    interval_us: int
    next_due_us: int


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
        specs: tuple[StreamSpec, ...] = DEFAULT_STREAMS,
        rates_hz: Mapping[str, float] | None = None,
    ) -> None:
        rates_hz = rates_hz or {}
        names = {spec.name for spec in specs}
        unknown = sorted(set(rates_hz) - names)
        if unknown:
            raise ValueError(f"unknown streams {unknown}; known: {sorted(names)}")
        self._streams: list[_Stream] = []
        self._by_id: dict[int, _Stream] = {}
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
        stream.next_due_us = now_us + interval_us if interval_us > 0 else _NEVER_US
        self.next_due_us = self._earliest()
        return True

    def pop_due(self, now_us: int) -> list[StreamSpec]:
        """Streams due at ``now_us``, rescheduled one interval later (no catch-up bursts)."""
        if now_us < self.next_due_us:
            return []
        due: list[StreamSpec] = []
        for stream in self._streams:
            if stream.next_due_us <= now_us:
                due.append(stream.spec)
                stream.next_due_us += stream.interval_us
                if stream.next_due_us <= now_us:
                    stream.next_due_us = now_us + stream.interval_us
        self.next_due_us = self._earliest()
        return due

    def restart(self, now_us: int) -> None:
        """Make every enabled stream due at ``now_us`` (after the clock went backwards)."""
        for stream in self._streams:
            if stream.interval_us > 0:
                stream.next_due_us = now_us
        self.next_due_us = self._earliest()
