"""The Earth as the sensors see it: gravity, the ISA troposphere and the geomagnetic field."""

from __future__ import annotations

import numpy as np

GRAVITY_M_S2 = 9.81
"""Magnitude of gravity used by the physics and the accelerometer model, m/s^2."""

ISA_SEA_LEVEL_PRESSURE_PA = 101325.0
"""ISA pressure at mean sea level, Pa."""
ISA_SEA_LEVEL_TEMPERATURE_K = 288.15
"""ISA temperature at mean sea level, K."""
ISA_LAPSE_RATE_K_M = 0.0065
"""ISA temperature lapse rate in the troposphere, K/m."""
ISA_PRESSURE_EXPONENT = 5.25588
"""ISA exponent g0 M / (R L) of the troposphere pressure law, dimensionless."""
KELVIN_AT_0_CELSIUS = 273.15
"""0 degrees Celsius, K."""


def isa_temperature_k(alt_amsl_m: np.ndarray) -> np.ndarray:
    """ISA air temperature at the given altitude(s) above mean sea level, K (troposphere)."""
    return ISA_SEA_LEVEL_TEMPERATURE_K - ISA_LAPSE_RATE_K_M * np.asarray(alt_amsl_m)


def isa_pressure_pa(alt_amsl_m: np.ndarray) -> np.ndarray:
    """ISA static pressure at the given altitude(s) above mean sea level, Pa (troposphere)."""
    ratio = isa_temperature_k(alt_amsl_m) / ISA_SEA_LEVEL_TEMPERATURE_K
    return ISA_SEA_LEVEL_PRESSURE_PA * ratio**ISA_PRESSURE_EXPONENT


def isa_pressure_altitude_m(pressure_pa: np.ndarray) -> np.ndarray:
    """Altitude above mean sea level, m, at which the ISA pressure equals the given pressure(s)."""
    ratio = (np.asarray(pressure_pa) / ISA_SEA_LEVEL_PRESSURE_PA) ** (1.0 / ISA_PRESSURE_EXPONENT)
    return (ISA_SEA_LEVEL_TEMPERATURE_K / ISA_LAPSE_RATE_K_M) * (1.0 - ratio)


def magnetic_field_ned_gauss(
    declination_deg: float, inclination_deg: float, strength_gauss: float
) -> np.ndarray:
    """Earth magnetic field vector in NED, gauss, from declination, inclination and strength.

    Declination is positive east of true north; inclination is positive pointing down.
    """
    dec = np.radians(declination_deg)
    inc = np.radians(inclination_deg)
    horizontal = strength_gauss * np.cos(inc)
    return np.array(
        [horizontal * np.cos(dec), horizontal * np.sin(dec), strength_gauss * np.sin(inc)]
    )
