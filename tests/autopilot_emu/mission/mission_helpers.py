"""Plans and geometry shared by the mission tests, independent of autopilot_emu.geodesy.

Positions are placed with a spherical small-offset projection (111195 m per degree of latitude,
times cos(latitude) per degree of longitude). It differs from the code's ellipsoidal tangent
plane by under 0.3 % (6 cm over 20 m), so a point put 10 m inside an area is inside it by any
reasonable projection, and distances agree to within 0.3 %.
"""

from __future__ import annotations

import math

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.items import MissionItem

LAT0, LON0, ALT0 = 47.397742, 8.545594, 488.0
"""Reference point (PX4's SITL home in Zurich), deg, deg, m AMSL."""
M_PER_DEG_LAT = 111195.0
M_PER_DEG_LON = M_PER_DEG_LAT * math.cos(math.radians(LAT0))

GLOBAL = mavlink2.MAV_FRAME_GLOBAL_INT
RELATIVE = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
MISSION = mavlink2.MAV_FRAME_MISSION


def offset(north_m: float, east_m: float) -> tuple[float, float]:
    """Latitude, longitude (deg) of a point north_m, east_m from the reference point."""
    return LAT0 + north_m / M_PER_DEG_LAT, LON0 + east_m / M_PER_DEG_LON


def to_ned(lat: float, lon: float, alt: float) -> np.ndarray:
    """Inverse of :func:`offset`, with down = ALT0 - alt."""
    return np.array([(lat - LAT0) * M_PER_DEG_LAT, (lon - LON0) * M_PER_DEG_LON, ALT0 - alt])


def item(
    command: int,
    north_m: float | None = None,
    east_m: float | None = None,
    z: float = 0.0,
    params: tuple[float, float, float, float] = (0.0, 0.0, 0.0, math.nan),
    frame: int = GLOBAL,
    autocontinue: bool = True,
) -> MissionItem:
    """An item at north_m, east_m from the reference point (None: no position, lat/lon 0)."""
    if north_m is None or east_m is None:
        x = y = 0
    else:
        lat, lon = offset(north_m, east_m)
        x, y = round(lat * 1e7), round(lon * 1e7)
    return MissionItem(command, frame, params, x, y, z, autocontinue)


def waypoint(north_m: float, east_m: float, alt_m: float = 10.0, **kw: object) -> MissionItem:
    """NAV_WAYPOINT at a height above home (relative frame)."""
    kw.setdefault("frame", RELATIVE)
    return item(mavlink2.MAV_CMD_NAV_WAYPOINT, north_m, east_m, alt_m, **kw)


def polygon(command: int, corners: list[tuple[float, float]]) -> list[MissionItem]:
    """One fence polygon: a vertex item per (north, east) corner, param1 = vertex count."""
    n = float(len(corners))
    return [item(command, north, east, params=(n, 0.0, 0.0, 0.0)) for north, east in corners]


def square(command: int, half_side_m: float, north_m: float = 0.0, east_m: float = 0.0):
    """A square polygon of side 2 * half_side_m centred north_m, east_m from the reference."""
    h = half_side_m
    corners = [(north_m - h, east_m - h), (north_m - h, east_m + h)]
    corners += [(north_m + h, east_m + h), (north_m + h, east_m - h)]
    return polygon(command, corners)


def circle(command: int, radius_m: float, north_m: float = 0.0, east_m: float = 0.0):
    """A fence circle of radius_m centred north_m, east_m from the reference."""
    return item(command, north_m, east_m, params=(radius_m, 0.0, 0.0, 0.0))
