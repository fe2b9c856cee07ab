"""GNSS receivers of N vehicles: position with a slowly wandering error, velocity with white noise.

PX4's Gazebo GPS plugin drives its error with densities multiplied (not divided) by sqrt(dt) at
the physics rate, which leaves centimetre-level errors. Here the errors are specified by their
standard deviations instead, so that they have the size of a real single-frequency receiver:

- position: a first-order Gauss-Markov error (correlation time as PX4's ``kGpsCorrelationTime``)
  plus small white noise, horizontal and vertical separately;
- velocity: white noise, horizontal and vertical separately.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sitl import frames
from sitl.sensors.noise import GaussMarkov


@dataclass(frozen=True)
class GpsParams:
    """Error model and reported quality of one GNSS receiver."""

    horizontal_bias_sigma_m: float
    """Stationary std of the slowly wandering position error, per horizontal axis, m."""
    vertical_bias_sigma_m: float
    """Stationary std of the slowly wandering position error, vertical, m."""
    bias_correlation_time_s: float
    """Correlation time of the wandering position error, s."""
    horizontal_noise_sigma_m: float
    """White position noise std per horizontal axis, m."""
    vertical_noise_sigma_m: float
    """White position noise std, vertical, m."""
    horizontal_velocity_noise_sigma_m_s: float
    """White velocity noise std per horizontal axis, m/s."""
    vertical_velocity_noise_sigma_m_s: float
    """White velocity noise std, vertical, m/s."""
    satellites_visible: int
    """Satellites reported in HIL_GPS, 1."""

    @property
    def eph_m(self) -> float:
        """Reported horizontal position accuracy (1 sigma per axis), m."""
        return float(np.hypot(self.horizontal_bias_sigma_m, self.horizontal_noise_sigma_m))

    @property
    def epv_m(self) -> float:
        """Reported vertical position accuracy (1 sigma), m."""
        return float(np.hypot(self.vertical_bias_sigma_m, self.vertical_noise_sigma_m))


@dataclass(frozen=True)
class GpsSample:
    """One GNSS fix of N vehicles."""

    lat_deg: np.ndarray
    """Latitude, degrees, (N,)."""
    lon_deg: np.ndarray
    """Longitude, degrees, (N,)."""
    alt_amsl_m: np.ndarray
    """Altitude above mean sea level, m, (N,)."""
    velocity_ned_m_s: np.ndarray
    """Velocity north, east, down, m/s, (N, 3)."""


class Gps:
    """GNSS receivers of N vehicles, antenna at the centre of mass."""

    def __init__(
        self,
        params: GpsParams,
        origin: frames.GeodeticOrigin,
        n_vehicles: int,
        rng: np.random.Generator,
    ) -> None:
        self.params = params
        self._origin = origin
        self._rng = rng
        h, v = params.horizontal_bias_sigma_m, params.vertical_bias_sigma_m
        self.bias_enu = GaussMarkov(
            np.tile([h, h, v], (n_vehicles, 1)), params.bias_correlation_time_s, rng
        )
        self._pos_sigma = np.array(
            [params.horizontal_noise_sigma_m] * 2 + [params.vertical_noise_sigma_m]
        )
        self._vel_sigma = np.array(
            [params.horizontal_velocity_noise_sigma_m_s] * 2
            + [params.vertical_velocity_noise_sigma_m_s]
        )

    def sample(
        self, position_enu_m: np.ndarray, velocity_enu_m_s: np.ndarray, dt_s: float
    ) -> GpsSample:
        """Measure at true positions/velocities (N, 3) ENU; ``dt_s`` is the time since the last."""
        z = self._rng.standard_normal((2, *position_enu_m.shape))
        pos = position_enu_m + self.bias_enu.advance(dt_s) + self._pos_sigma * z[0]
        vel = velocity_enu_m_s + self._vel_sigma * z[1]
        lat, lon, alt = frames.enu_to_geodetic(pos, self._origin)
        return GpsSample(
            lat_deg=lat, lon_deg=lon, alt_amsl_m=alt, velocity_ned_m_s=frames.enu_to_ned(vel)
        )
