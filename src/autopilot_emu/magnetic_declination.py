"""Magnetic declination as the autopilot looks it up from its own GPS origin (PX4 geo lookup).

PX4 does not take the declination from the simulator: when EKF2 sets its origin from the first
good GPS fix it reads declination, inclination and strength from ``geo_magnetic_tables.hpp``, the
World Magnetic Model sampled every 10 degrees of latitude and longitude at the epoch the
firmware's table was generated, and interpolates bilinearly (``lib/world_magnetic_model``). It
uses that value when bit 0 of EKF2_DECL_TYPE is set (default 7) and EKF2_MAG_DECL otherwise; with
bit 1 set it saves the looked-up value to EKF2_MAG_DECL (PX4: on disarm) so that the next start
begins with it.

Here the table nodes are evaluated on demand with ``pygeomag`` (WMM) at ``TABLE_DECIMAL_YEAR``
and sea level, and interpolated the same way, so the autopilot's value carries the same kind of
interpolation and epoch error as PX4's, independent of the simulator's model.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
from pygeomag import GeoMag

from autopilot_emu.params import ParamStore

GRID_RESOLUTION_DEG = 10.0
"""Spacing of the lookup table in latitude and longitude, degrees (PX4 SAMPLING_RES)."""
TABLE_DECIMAL_YEAR = 2026.0
"""Epoch of the emulated firmware's table, decimal year."""
GEO_LOOKUP_BIT = 1
"""EKF2_DECL_TYPE bit 0: use the declination looked up at the origin."""
SAVE_GEO_DECL_BIT = 2
"""EKF2_DECL_TYPE bit 1: save the looked-up declination to EKF2_MAG_DECL."""
SAVE_THRESHOLD_DEG = 0.1
"""Smallest change of EKF2_MAG_DECL worth saving, degrees (ours: no churn of the parameter)."""


@cache
def _model() -> GeoMag:
    return GeoMag()


@cache
def _node_declination_deg(lat_deg: float, lon_deg: float) -> float:
    """WMM declination at one table node (sea level, table epoch), degrees."""
    return float(_model().calculate(glat=lat_deg, glon=lon_deg, alt=0.0, time=TABLE_DECIMAL_YEAR).d)


def lookup_declination_deg(lat_deg: float, lon_deg: float) -> float:
    """Declination at a point from the 10-degree table, bilinear interpolation, degrees east."""
    lat = min(max(float(lat_deg), -90.0), 90.0)
    lon = min(max(float(lon_deg), -180.0), 180.0)
    res = GRID_RESOLUTION_DEG
    lat0 = min(math.floor(lat / res) * res, 90.0 - res)
    lon0 = min(math.floor(lon / res) * res, 180.0 - res)
    corners = np.array(
        [
            [_node_declination_deg(lat0, lon0), _node_declination_deg(lat0, lon0 + res)],
            [
                _node_declination_deg(lat0 + res, lon0),
                _node_declination_deg(lat0 + res, lon0 + res),
            ],
        ]
    )
    # Interpolate angle differences, so nodes on either side of +-180 degrees do not average out.
    corners = corners[0, 0] + (corners - corners[0, 0] + 180.0) % 360.0 - 180.0
    u, v = (lat - lat0) / res, (lon - lon0) / res
    south = corners[0, 0] + v * (corners[0, 1] - corners[0, 0])
    north = corners[1, 0] + v * (corners[1, 1] - corners[1, 0])
    return float((south + u * (north - south) + 180.0) % 360.0 - 180.0)


def declinations_deg(
    params: list[ParamStore], origin_lla: np.ndarray, origin_set: np.ndarray
) -> np.ndarray:
    """Declination each vehicle's estimator uses, (N,) degrees.

    The table value at its origin when the origin is set and EKF2_DECL_TYPE has the geo-lookup
    bit; EKF2_MAG_DECL otherwise.
    """
    out = np.empty(len(params))
    for i, p in enumerate(params):
        lookup = int(p.get("EKF2_DECL_TYPE")) & GEO_LOOKUP_BIT
        if lookup and origin_set[i]:
            out[i] = lookup_declination_deg(origin_lla[i, 0], origin_lla[i, 1])
        else:
            out[i] = float(p.get("EKF2_MAG_DECL"))
    return out


def on_new_origin(
    params: list[ParamStore], origin_lla: np.ndarray, origin_set: np.ndarray, new: np.ndarray
) -> np.ndarray:
    """Declinations after origins were set (mask ``new``), saving them where EKF2_DECL_TYPE asks.

    PX4 saves at the next disarm; an origin is set before arming, so it is saved at once.
    """
    result = declinations_deg(params, origin_lla, origin_set)
    for i in np.flatnonzero(new):
        p = params[i]
        save = int(p.get("EKF2_DECL_TYPE")) & (GEO_LOOKUP_BIT | SAVE_GEO_DECL_BIT)
        changed = abs(result[i] - float(p.get("EKF2_MAG_DECL"))) > SAVE_THRESHOLD_DEG
        if save == GEO_LOOKUP_BIT | SAVE_GEO_DECL_BIT and changed:
            p.set("EKF2_MAG_DECL", float(result[i]))
    return result
