"""Local tangent-plane projection between geodetic coordinates and each vehicle's NED frame.

PX4 projects around its EKF origin (map_projection); here the projection is the tangent plane of
the WGS84 ellipsoid at the origin, linearised with the meridian and prime-vertical radii of
curvature there. Over the few hundred metres a SITL vehicle flies, it differs from the exact
ellipsoidal transform by millimetres (error grows as distance² / earth radius), and it costs a
handful of multiplications instead of an iterative ECEF conversion on every telemetry message.
"""

from __future__ import annotations

import numpy as np

WGS84_A_M = 6378137.0
WGS84_E2 = 6.69437999014e-3


def radii_of_curvature(lat_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Meridian (north) and prime-vertical (east) radii of curvature at lat, m."""
    s = np.sin(np.radians(lat_deg))
    w = np.sqrt(1.0 - WGS84_E2 * s * s)
    return WGS84_A_M * (1.0 - WGS84_E2) / w**3, WGS84_A_M / w


def metres_per_degree(origin: np.ndarray) -> np.ndarray:
    """(..., 2) metres per degree of latitude and of longitude at each origin (lat, lon, alt)."""
    rm, rn = radii_of_curvature(origin[..., 0])
    per_rad = np.stack(
        (rm + origin[..., 2], (rn + origin[..., 2]) * np.cos(np.radians(origin[..., 0]))), axis=-1
    )
    return np.radians(per_rad)


def geodetic_to_ned(lla: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(N, 3) lat/lon (deg), alt AMSL (m) -> NED (m) around per-row origins (N, 3)."""
    scale = metres_per_degree(origin)
    north = (lla[..., 0] - origin[..., 0]) * scale[..., 0]
    east = (lla[..., 1] - origin[..., 1]) * scale[..., 1]
    return np.stack((north, east, origin[..., 2] - lla[..., 2]), axis=-1)


def ned_to_geodetic(ned: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Inverse of :func:`geodetic_to_ned`."""
    scale = metres_per_degree(origin)
    lat = origin[..., 0] + ned[..., 0] / scale[..., 0]
    lon = origin[..., 1] + ned[..., 1] / scale[..., 1]
    return np.stack((lat, lon, origin[..., 2] - ned[..., 2]), axis=-1)
