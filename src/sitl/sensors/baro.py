"""Barometers of N vehicles: ISA static pressure at the altitude AMSL, plus noise."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sitl.physics.earth import (
    KELVIN_AT_0_CELSIUS,
    isa_pressure_altitude_m,
    isa_pressure_pa,
    isa_temperature_k,
)


@dataclass(frozen=True)
class BaroParams:
    """Noise of one barometer."""

    pressure_noise_pa: float
    """White noise on the static pressure, standard deviation, Pa."""
    drift_pa_s: float
    """Constant pressure drift rate, Pa/s (PX4 Gazebo ``baroDriftPaPerSec``)."""


@dataclass(frozen=True)
class BaroSample:
    """One barometer reading of N vehicles, as HIL_SENSOR carries it."""

    abs_pressure_hpa: np.ndarray
    """Static pressure, hPa, (N,)."""
    pressure_alt_m: np.ndarray
    """ISA pressure altitude of the noisy pressure, m AMSL, (N,)."""
    temperature_c: np.ndarray
    """Air temperature, degrees Celsius, (N,)."""


class Barometer:
    """Barometers of N vehicles."""

    def __init__(self, params: BaroParams, n_vehicles: int, rng: np.random.Generator) -> None:
        self.params = params
        self._rng = rng
        self._n = n_vehicles
        self._drift_pa = 0.0

    def sample(self, alt_amsl_m: np.ndarray, dt_s: float) -> BaroSample:
        """Measure at altitudes AMSL ``alt_amsl_m`` (N,); ``dt_s``: time since the last sample."""
        self._drift_pa += self.params.drift_pa_s * dt_s
        pressure_pa = (
            isa_pressure_pa(alt_amsl_m)
            + self._drift_pa
            + self.params.pressure_noise_pa * self._rng.standard_normal(self._n)
        )
        return BaroSample(
            abs_pressure_hpa=pressure_pa * 0.01,
            pressure_alt_m=isa_pressure_altitude_m(pressure_pa),
            temperature_c=isa_temperature_k(alt_amsl_m) - KELVIN_AT_0_CELSIUS,
        )
