"""The autopilot's own declination lookup (PX4 geo lookup, EKF2_DECL_TYPE, EKF2_MAG_DECL)."""

from __future__ import annotations

import numpy as np
import pytest
from pygeomag import GeoMag

from autopilot_emu import magnetic_declination as md
from autopilot_emu.params import ParamStore


def _wmm_deg(lat: float, lon: float) -> float:
    return GeoMag().calculate(glat=lat, glon=lon, alt=0.0, time=md.TABLE_DECIMAL_YEAR).d


@pytest.mark.parametrize(
    ("lat", "lon"), [(47.397742, 8.545594), (-33.9, 151.2), (40.0, -100.0), (64.1, -21.9)]
)
def test_table_lookup_is_close_to_the_model(lat, lon):
    """Bilinear interpolation of the 10-degree table stays within 1.5 degrees of the WMM at
    inhabited latitudes, and is exact on a table node."""
    assert md.lookup_declination_deg(lat, lon) == pytest.approx(_wmm_deg(lat, lon), abs=1.5)
    assert md.lookup_declination_deg(40.0, 10.0) == pytest.approx(_wmm_deg(40.0, 10.0), abs=1e-9)


def test_lookup_is_continuous_across_the_date_line_and_near_the_poles():
    """Nodes on either side of +-180 degrees interpolate as angles (no jump through 0)."""
    for lat in (-75.0, -45.0, 65.0, 85.0):
        west = md.lookup_declination_deg(lat, 179.999)
        east = md.lookup_declination_deg(lat, -179.999)
        assert abs((west - east + 180.0) % 360.0 - 180.0) < 0.1
    assert np.isfinite(md.lookup_declination_deg(90.0, 180.0))


def test_decl_type_selects_the_lookup_or_the_parameter():
    """Bit 0 with an origin: the lookup; without an origin or with bit 0 off: EKF2_MAG_DECL."""
    params = [ParamStore() for _ in range(3)]
    for p in params:
        p.set("EKF2_MAG_DECL", -5.0)
    params[2].set("EKF2_DECL_TYPE", 0)
    origin = np.array([[-33.9, 151.2, 30.0]] * 3)
    got = md.declinations_deg(params, origin, np.array([True, False, True]))
    assert got[0] == pytest.approx(md.lookup_declination_deg(-33.9, 151.2))
    assert got[0] == pytest.approx(12.8, abs=1.5)
    assert got[1] == -5.0 and got[2] == -5.0


def test_new_origin_saves_the_lookup_only_with_bit_1():
    """EKF2_DECL_TYPE 7 (PX4 default) saves the looked-up value to EKF2_MAG_DECL; 1 does not."""
    params = [ParamStore(), ParamStore()]
    assert int(params[0].get("EKF2_DECL_TYPE")) == 7
    assert float(params[0].get("EKF2_MAG_DECL")) == 0.0  # PX4's default, not the world's value
    params[1].set("EKF2_DECL_TYPE", 1)
    origin = np.array([[-33.9, 151.2, 30.0]] * 2)
    both = np.array([True, True])
    got = md.on_new_origin(params, origin, both, both)
    assert got == pytest.approx([md.lookup_declination_deg(-33.9, 151.2)] * 2)
    assert float(params[0].get("EKF2_MAG_DECL")) == pytest.approx(got[0], abs=1e-4)
    assert float(params[1].get("EKF2_MAG_DECL")) == 0.0
