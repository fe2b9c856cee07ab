"""The latest reading of every distance sensor of every vehicle (PX4's distance_sensor topics).

PX4's simulator module turns each DISTANCE_SENSOR from the simulator into a ``distance_sensor``
uORB message, one instance per sensor; EKF2 reads the downward-facing one and the MAVLink
DISTANCE_SENSOR stream forwards each instance that was updated. Here the readings arrive as
DISTANCE_SENSOR messages (pymavlink objects, in memory or from a socket), one list per vehicle, and
are kept per (vehicle, sensor id) in SI units. Each new reading gets a sequence number so that
every MAVLink link can tell which readings it has not forwarded yet.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

ROTATION_DOWNWARD = mavlink2.MAV_SENSOR_ROTATION_PITCH_270
"""MAV_SENSOR_ROTATION of a downward-facing sensor (PX4's ROTATION_DOWNWARD_FACING)."""
SIGNAL_QUALITY_INVALID = 1
"""DISTANCE_SENSOR signal_quality of an invalid reading (0 unknown, 100 perfect)."""


@dataclass(slots=True)
class RangeReading:
    """One sensor's latest reading, as PX4's distance_sensor message holds it (SI units)."""

    time_usec: int
    """Time of the reading since boot, us."""
    sensor_id: int
    """DISTANCE_SENSOR id."""
    orientation: int
    """MAV_SENSOR_ROTATION."""
    sensor_type: int
    """MAV_DISTANCE_SENSOR."""
    distance_m: float
    """Measured distance, m (as sent: may lie outside [min_m, max_m] when there is no echo)."""
    min_m: float
    """Shortest valid distance, m."""
    max_m: float
    """Longest valid distance, m."""
    covariance_cm2: int
    """DISTANCE_SENSOR covariance, cm^2 (255 unknown)."""
    horizontal_fov_rad: float
    vertical_fov_rad: float
    signal_quality: int
    """0 unknown, 1 invalid, 100 perfect (MAVLink)."""
    seq: int
    """Order of arrival over all sensors of the vehicle (starts at 1)."""

    @property
    def valid(self) -> bool:
        """In range and not flagged invalid: a distance EKF2 would use."""
        return (
            self.signal_quality != SIGNAL_QUALITY_INVALID
            and self.min_m <= self.distance_m <= self.max_m
        )

    def message(self) -> mavlink2.MAVLink_distance_sensor_message:
        """This reading as DISTANCE_SENSOR (what PX4's DISTANCE_SENSOR stream sends)."""
        return mavlink2.MAVLink_distance_sensor_message(
            time_boot_ms=(self.time_usec // 1000) & 0xFFFFFFFF,
            min_distance=_cm(self.min_m),
            max_distance=_cm(self.max_m),
            current_distance=_cm(self.distance_m),
            type=self.sensor_type,
            id=self.sensor_id,
            orientation=self.orientation,
            covariance=self.covariance_cm2,
            horizontal_fov=self.horizontal_fov_rad,
            vertical_fov=self.vertical_fov_rad,
            quaternion=[0.0, 0.0, 0.0, 0.0],
            signal_quality=self.signal_quality,
        )


def _cm(metres: float) -> int:
    return min(max(round(metres * 100.0), 0), 65535) if math.isfinite(metres) else 65535


class FleetRangefinders:
    """Latest readings of N vehicles' distance sensors, and their downward-facing one."""

    def __init__(self, n: int) -> None:
        self.n = n
        self._latest: list[dict[int, RangeReading]] = [{} for _ in range(n)]
        self._tuples: list[tuple[RangeReading, ...]] = [() for _ in range(n)]
        self._seq = [0] * n
        self.down_distance_m = np.full(n, np.nan)
        """Latest downward reading of each vehicle, m (NaN: none yet)."""
        self.down_valid = np.zeros(n, dtype=bool)
        """Whether that reading is valid (in range, with an echo)."""
        self.down_variance_m2 = np.full(n, np.nan)
        """Its variance as the sensor reported it, m² (NaN unknown)."""

    def update(
        self, msgs: Sequence[Sequence[mavlink2.MAVLink_distance_sensor_message]]
    ) -> np.ndarray:
        """Store one list of DISTANCE_SENSOR per vehicle; which vehicles got a downward reading.

        Malformed messages (not a DISTANCE_SENSOR) are skipped.
        """
        if len(msgs) != self.n:
            raise ValueError(f"expected {self.n} lists of DISTANCE_SENSOR, got {len(msgs)}")
        new_down = np.zeros(self.n, dtype=bool)
        for i, vehicle_msgs in enumerate(msgs):
            if not vehicle_msgs:
                continue
            latest = self._latest[i]
            for m in vehicle_msgs:
                if not isinstance(m, mavlink2.MAVLink_distance_sensor_message):
                    continue
                self._seq[i] += 1
                reading = RangeReading(
                    time_usec=int(m.time_boot_ms) * 1000,
                    sensor_id=int(m.id),
                    orientation=int(m.orientation),
                    sensor_type=int(m.type),
                    distance_m=m.current_distance * 0.01,
                    min_m=m.min_distance * 0.01,
                    max_m=m.max_distance * 0.01,
                    covariance_cm2=int(m.covariance),
                    horizontal_fov_rad=float(m.horizontal_fov),
                    vertical_fov_rad=float(m.vertical_fov),
                    signal_quality=int(m.signal_quality),
                    seq=self._seq[i],
                )
                latest[reading.sensor_id] = reading
                if reading.orientation == ROTATION_DOWNWARD:
                    new_down[i] = True
                    self.down_distance_m[i] = reading.distance_m
                    self.down_valid[i] = reading.valid
                    cov = reading.covariance_cm2
                    self.down_variance_m2[i] = cov * 1e-4 if cov < 255 else np.nan
            self._tuples[i] = tuple(latest[k] for k in sorted(latest))
        return new_down

    def readings(self, i: int) -> tuple[RangeReading, ...]:
        """Vehicle i's latest reading of each sensor, by sensor id (an immutable snapshot)."""
        return self._tuples[i]
