"""The world's magnetic field comes from the World Magnetic Model at its origin and date."""

from __future__ import annotations

import datetime

import numpy as np
import pytest
from pygeomag import GeoMag
from sitl_test_helpers import collect, make_world, sensor_array

from sitl.physics.geomagnetism import decimal_year, world_magnetic_model

ZURICH = (47.397742, 8.545594, 488.0)
SYDNEY = (-33.9, 151.2, 30.0)


def _reference(lat: float, lon: float, alt_m: float, year: float):
    """pygeomag called directly (altitude in km, intensity in nT)."""
    return GeoMag().calculate(glat=lat, glon=lon, alt=alt_m / 1000.0, time=year)


@pytest.mark.parametrize("place", [ZURICH, SYDNEY])
def test_field_is_the_wmm_at_the_place(place):
    """Declination, inclination and strength equal the WMM's (nT -> gauss)."""
    field = world_magnetic_model(*place, 2026.0)
    ref = _reference(*place, 2026.0)
    assert field.declination_deg == pytest.approx(ref.d, abs=1e-9)
    assert field.inclination_deg == pytest.approx(ref.i, abs=1e-9)
    assert field.strength_gauss == pytest.approx(ref.f * 1e-5, rel=1e-12)


def test_default_world_uses_the_model_not_a_constant():
    """Zurich 2026: east declination ~3.5 deg, dip ~63.5 deg, ~0.48 gauss; Sydney differs:
    declination ~12.8 deg east and the field points up (southern hemisphere)."""
    zurich = make_world().magnetic_field
    assert zurich.declination_deg == pytest.approx(3.5, abs=0.3)
    assert zurich.inclination_deg == pytest.approx(63.5, abs=0.5)
    assert zurich.strength_gauss == pytest.approx(0.48, abs=0.01)
    sydney = make_world(origin_lat_deg=SYDNEY[0], origin_lon_deg=SYDNEY[1]).magnetic_field
    assert sydney.declination_deg == pytest.approx(12.8, abs=0.5)
    assert sydney.inclination_deg < -60.0


def test_date_moves_the_field_and_has_a_life_span():
    """Secular variation: Zurich's declination grows east by ~0.1-0.3 deg per year; a date outside
    WMM2025's life span fails naming the year."""
    early = world_magnetic_model(*ZURICH, 2025.5).declination_deg
    late = world_magnetic_model(*ZURICH, 2029.5).declination_deg
    assert 0.1 * 4 < late - early < 0.3 * 4
    with pytest.raises(ValueError, match="2035"):
        make_world(mag_model_decimal_year=2035.0)
    assert decimal_year(datetime.date(2026, 1, 1)) == 2026.0
    assert decimal_year(datetime.date(2026, 7, 2)) == pytest.approx(2026.5, abs=0.003)


def test_explicit_overrides_win():
    """A configured declination / inclination / strength replaces the model's, per field."""
    world = make_world(mag_declination_deg=-20.0, mag_strength_gauss=0.3)
    sensors, _ = collect(world, 1.0)
    world.close()
    field = world.magnetic_field
    assert (field.declination_deg, field.strength_gauss) == (-20.0, 0.3)
    assert field.inclination_deg == pytest.approx(
        world_magnetic_model(*ZURICH, 2026.0).inclination_deg
    )
    mag = sensor_array(sensors, 0, ("xmag", "ymag", "zmag")).mean(axis=0)
    assert np.degrees(np.arctan2(mag[1], mag[0])) == pytest.approx(-20.0, abs=0.5)
    assert np.linalg.norm(mag) == pytest.approx(0.3, abs=0.005)
