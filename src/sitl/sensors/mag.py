"""Magnetometers of N vehicles, body FRD, gauss."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sitl import frames
from sitl.sensors.noise import BiasedWhiteNoise
from sitl.sensors.noise_kernel import field_in_body


@dataclass(frozen=True)
class MagParams:
    """Noise of one magnetometer (PX4 Gazebo ``magnetometer_plugin`` parameters)."""

    noise_density_gauss_sqrt_hz: float
    """White-noise density, gauss/sqrt(Hz)."""
    random_walk_gauss_s_sqrt_hz: float
    """Bias random-walk density, gauss/s/sqrt(Hz)."""
    bias_correlation_time_s: float
    """Bias correlation time, s."""


class Magnetometer:
    """Magnetometers of N vehicles in a uniform Earth field (no hard/soft iron: PX4 calibrates)."""

    def __init__(
        self,
        params: MagParams,
        field_ned_gauss: np.ndarray,
        n_vehicles: int,
        rng: np.random.Generator,
    ) -> None:
        self.params = params
        self._field_enu = np.ascontiguousarray(
            np.broadcast_to(frames.ned_to_enu(field_ned_gauss), (n_vehicles, 3))
        )
        self.noise = BiasedWhiteNoise(
            (n_vehicles, 3),
            params.noise_density_gauss_sqrt_hz,
            params.random_walk_gauss_s_sqrt_hz,
            params.bias_correlation_time_s,
            0.0,
            rng,
        )

    def sample(self, rotation_flu_to_enu: np.ndarray, dt_s: float, out: np.ndarray) -> None:
        """Measure the field in body FRD, gauss, into ``out`` (N, 3).

        ``dt_s`` is the time since the previous sample.
        """
        field_in_body(rotation_flu_to_enu, self._field_enu, self.noise.sample(dt_s), out)
