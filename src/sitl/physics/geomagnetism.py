"""The Earth's main magnetic field from the World Magnetic Model (WMM), through ``pygeomag``.

``pygeomag`` is a pure-Python port of NOAA/NCEI's WMM software and ships its coefficient files
(WMM2025, valid 2025.0 to 2030.0). The field is evaluated once per world, at the origin, on the
configured date: over a flying area of kilometres it changes by far less than the magnetometer
noise (at Zurich this model's declination changes by 0.03 degree and its inclination by 0.08
degree over 10 km).
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass
from functools import cache

import numpy as np
from pygeomag import GeoMag

from sitl.physics.earth import magnetic_field_ned_gauss

NANOTESLA_PER_GAUSS = 1.0e5
"""1 gauss = 1e-4 T = 1e5 nT."""


@dataclass(frozen=True)
class GeomagneticField:
    """Field at one place and date (degrees east of true north, degrees below horizontal)."""

    declination_deg: float
    """Declination, degrees, positive east."""
    inclination_deg: float
    """Inclination (dip), degrees, positive down."""
    strength_gauss: float
    """Total intensity, gauss."""

    def ned_gauss(self) -> np.ndarray:
        """Field vector in NED, gauss."""
        return magnetic_field_ned_gauss(
            self.declination_deg, self.inclination_deg, self.strength_gauss
        )


@cache
def _model() -> GeoMag:
    return GeoMag()  # the newest coefficients pygeomag ships (WMM2025)


def decimal_year(date: datetime.date) -> float:
    """Decimal year of a date's midnight, as WMM takes it (2026-01-01 -> 2026.0)."""
    start = datetime.date(date.year, 1, 1)
    days = (datetime.date(date.year + 1, 1, 1) - start).days
    return date.year + (date - start).days / days


def world_magnetic_model(
    lat_deg: float, lon_deg: float, alt_amsl_m: float, decimal_year: float
) -> GeomagneticField:
    """WMM field at a geodetic point (altitude AMSL taken as height above the ellipsoid).

    Raises:
        ValueError: the date is outside the coefficients' five-year life span.
    """
    try:
        r = _model().calculate(
            glat=float(lat_deg), glon=float(lon_deg), alt=alt_amsl_m / 1000.0, time=decimal_year
        )
    except ValueError as exc:
        raise ValueError(f"world magnetic model at year {decimal_year}: {exc}") from exc
    return GeomagneticField(
        declination_deg=float(r.d),
        inclination_deg=float(r.i),
        strength_gauss=float(r.f) / NANOTESLA_PER_GAUSS,
    )
