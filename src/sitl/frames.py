"""Every frame convention of the simulator, in one place.

Inside PyBullet the world frame is ENU (x east, y north, z up, origin on the ground under the
geodetic origin) and the body frame is FLU (x forward, y left, z up). At the MAVLink boundary the
world frame is NED and the body frame FRD, as PX4 uses them.

Quaternions: PyBullet orders them ``(x, y, z, w)``; PX4 and MAVLink order them ``(w, x, y, z)``.
All are Hamilton quaternions that rotate body coordinates into world coordinates.

Geodetic positions: WGS-84 latitude and longitude in degrees of the local ENU frame tangent to the
ellipsoid at the world origin, as pymap3d defines it. ``enu_to_geodetic`` runs at the GPS rate, so
it rotates into ECEF with a matrix precomputed from the origin (origin ECEF from pymap3d) and
solves ECEF -> latitude in closed form (Bowring 1976): it agrees with pymap3d.enu2geodetic to
better than a micrometre within 20 km, at an eighth of its cost (pymap3d's general solver costs
~100 us a call). ``geodetic_to_enu`` is pymap3d's. Altitude above mean sea level is the origin's
altitude plus ENU up: the simulated ground is a flat plane, so a vehicle standing on it reads the
same altitude everywhere, as PX4's flat local frame expects (the tangent plane itself rises
d^2 / 2R above the ellipsoid, 2 m at 5 km). The geoid undulation is ignored.

Every function accepts one vector of shape ``(3,)`` (or ``(4,)`` for quaternions) or a stack of
shape ``(..., 3)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import pymap3d

_ENU_NED_SIGN = np.array([1.0, 1.0, -1.0])
_FLU_FRD_SIGN = np.array([1.0, -1.0, -1.0])

_SQRT_HALF = np.sqrt(0.5)
# Rotation taking ENU coordinates to NED coordinates: pi about (1, 1, 0)/sqrt(2), (w, x, y, z).
_Q_NED_FROM_ENU = np.array([0.0, _SQRT_HALF, _SQRT_HALF, 0.0])
# Rotation taking FRD coordinates to FLU coordinates: pi about x, (w, x, y, z).
_Q_FLU_FROM_FRD = np.array([0.0, 1.0, 0.0, 0.0])


_WGS84 = pymap3d.Ellipsoid.from_name("wgs84")
_A_M = _WGS84.semimajor_axis
_B_M = _WGS84.semiminor_axis
_E2 = 1.0 - (_B_M / _A_M) ** 2  # first eccentricity squared
_EP2 = (_A_M / _B_M) ** 2 - 1.0  # second eccentricity squared


@dataclass(frozen=True)
class GeodeticOrigin:
    """Geodetic position of the local ENU origin (a point on the ground plane)."""

    lat_deg: float
    """Latitude, degrees (WGS-84)."""
    lon_deg: float
    """Longitude, degrees (WGS-84)."""
    alt_amsl_m: float
    """Altitude of the ground plane above mean sea level, m."""

    @cached_property
    def ecef_m(self) -> np.ndarray:
        """ECEF position of the origin, m (pymap3d)."""
        return np.array(pymap3d.geodetic2ecef(self.lat_deg, self.lon_deg, self.alt_amsl_m))

    @cached_property
    def enu_to_ecef_rows(self) -> np.ndarray:
        """Matrix M with ``ecef = origin + enu @ M`` (rows: E, N, U axes in ECEF)."""
        phi, lam = np.radians(self.lat_deg), np.radians(self.lon_deg)
        return np.array(
            [
                [-np.sin(lam), np.cos(lam), 0.0],
                [-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)],
                [np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)],
            ]
        )


def enu_to_ned(v_enu: np.ndarray) -> np.ndarray:
    """World vector(s) from ENU to NED coordinates."""
    v = np.asarray(v_enu, dtype=float)
    return v[..., [1, 0, 2]] * _ENU_NED_SIGN


def ned_to_enu(v_ned: np.ndarray) -> np.ndarray:
    """World vector(s) from NED to ENU coordinates."""
    v = np.asarray(v_ned, dtype=float)
    return v[..., [1, 0, 2]] * _ENU_NED_SIGN


def flu_to_frd(v_flu: np.ndarray) -> np.ndarray:
    """Body vector(s) from FLU to FRD coordinates."""
    return np.asarray(v_flu, dtype=float) * _FLU_FRD_SIGN


def frd_to_flu(v_frd: np.ndarray) -> np.ndarray:
    """Body vector(s) from FRD to FLU coordinates."""
    return np.asarray(v_frd, dtype=float) * _FLU_FRD_SIGN


def _quat_mul_wxyz(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of (w, x, y, z) quaternions, broadcasting over leading axes."""
    aw, ax, ay, az = np.moveaxis(np.asarray(a, dtype=float), -1, 0)
    bw, bx, by, bz = np.moveaxis(np.asarray(b, dtype=float), -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def _canonical(q_wxyz: np.ndarray) -> np.ndarray:
    """Normalise and choose the sign with w >= 0 (q and -q are the same rotation)."""
    q = q_wxyz / np.linalg.norm(q_wxyz, axis=-1, keepdims=True)
    return np.where(q[..., :1] < 0.0, -q, q)


def quat_enu_flu_to_ned_frd(q_xyzw: np.ndarray) -> np.ndarray:
    """Attitude FLU->ENU as PyBullet (x, y, z, w) to attitude FRD->NED as PX4 (w, x, y, z)."""
    q = np.asarray(q_xyzw, dtype=float)
    q_wxyz = q[..., [3, 0, 1, 2]]
    return _canonical(_quat_mul_wxyz(_quat_mul_wxyz(_Q_NED_FROM_ENU, q_wxyz), _Q_FLU_FROM_FRD))


def quat_ned_frd_to_enu_flu(q_wxyz: np.ndarray) -> np.ndarray:
    """Attitude FRD->NED as PX4 (w, x, y, z) to attitude FLU->ENU as PyBullet (x, y, z, w)."""
    # Both fixed rotations are half-turns, so each is its own inverse.
    q = _canonical(
        _quat_mul_wxyz(_quat_mul_wxyz(_Q_NED_FROM_ENU, np.asarray(q_wxyz)), _Q_FLU_FROM_FRD)
    )
    return q[..., [1, 2, 3, 0]]


def quat_from_euler_ned_frd(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """Attitude FRD->NED (w, x, y, z) from PX4 Euler angles (yaw-pitch-roll, yaw 0 = north)."""
    cr, sr = np.cos(roll_rad / 2.0), np.sin(roll_rad / 2.0)
    cp, sp = np.cos(pitch_rad / 2.0), np.sin(pitch_rad / 2.0)
    cy, sy = np.cos(yaw_rad / 2.0), np.sin(yaw_rad / 2.0)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def euler_from_quat_ned_frd(q_wxyz: np.ndarray) -> np.ndarray:
    """PX4 Euler angles ``[..., (roll, pitch, yaw)]``, rad, of attitude(s) FRD->NED (w, x, y, z)."""
    w, x, y, z = np.moveaxis(np.asarray(q_wxyz, dtype=float), -1, 0)
    roll = np.arctan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=-1)


def rotation_matrix_xyzw(q_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of (x, y, z, w) quaternions: ``v_world = R @ v_body``."""
    x, y, z, w = np.moveaxis(np.asarray(q_xyzw, dtype=float), -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def world_enu_to_body_frd(
    rot_flu_to_enu: np.ndarray, v_enu: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """World ENU vector(s) expressed in the body FRD frame, given the FLU->ENU rotation(s).

    Args:
        rot_flu_to_enu: rotation matrices, ``(..., 3, 3)``.
        v_enu: one vector per rotation ``(..., 3)``, or k row vectors per rotation ``(..., k, 3)``.
        out: optional array of the result's shape to write into (k row vectors only).
    """
    rot = np.asarray(rot_flu_to_enu)
    v = np.asarray(v_enu, dtype=float)
    if v.ndim == rot.ndim - 1:
        v_flu = np.matmul(v[..., None, :], rot)[..., 0, :]
    else:
        v_flu = np.matmul(v, rot, out=out)  # row vectors: v^T R = (R^T v)^T
    np.multiply(v_flu, _FLU_FRD_SIGN, out=v_flu)
    return v_flu


def body_frd_to_world_enu(rot_flu_to_enu: np.ndarray, v_frd: np.ndarray) -> np.ndarray:
    """Body FRD vector(s) expressed in the world ENU frame, given the FLU->ENU rotation(s)."""
    v_flu = np.asarray(v_frd, dtype=float) * _FLU_FRD_SIGN
    return np.matmul(rot_flu_to_enu, v_flu[..., None])[..., 0]


def enu_to_geodetic(
    position_enu_m: np.ndarray, origin: GeodeticOrigin
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude (deg), longitude (deg) and altitude AMSL (m) of local ENU position(s)."""
    p = np.asarray(position_enu_m, dtype=float)
    ecef = origin.ecef_m + p @ origin.enu_to_ecef_rows
    x, y, z = ecef[..., 0], ecef[..., 1], ecef[..., 2]
    r_xy = np.hypot(x, y)
    theta = np.arctan2(z * _A_M, r_xy * _B_M)
    lat = np.arctan2(z + _EP2 * _B_M * np.sin(theta) ** 3, r_xy - _E2 * _A_M * np.cos(theta) ** 3)
    return np.degrees(lat), np.degrees(np.arctan2(y, x)), origin.alt_amsl_m + p[..., 2]


def geodetic_to_enu(
    lat_deg: np.ndarray, lon_deg: np.ndarray, alt_amsl_m: np.ndarray, origin: GeodeticOrigin
) -> np.ndarray:
    """Local ENU position(s) in m of geodetic position(s); inverse of ``enu_to_geodetic``."""
    lat0, lon0, h0 = origin.lat_deg, origin.lon_deg, origin.alt_amsl_m
    up = np.asarray(alt_amsl_m, dtype=float) - h0
    # pymap3d needs the ellipsoidal height of the point: guess it, then correct it once (the
    # residual is of order (d / R)^3 d, below a micrometre at 10 km).
    e, n, _ = pymap3d.geodetic2enu(lat_deg, lon_deg, h0 + up, lat0, lon0, h0)
    _, _, h_ell = pymap3d.enu2geodetic(e, n, up, lat0, lon0, h0)
    e, n, _ = pymap3d.geodetic2enu(lat_deg, lon_deg, h_ell, lat0, lon0, h0)
    return np.stack([np.asarray(e), np.asarray(n), np.broadcast_to(up, np.shape(e))], axis=-1)


def camera_attitude_ned(
    vehicle_q_xyzw: np.ndarray, mount_pitch_deg: float, mount_yaw_deg: float
) -> np.ndarray:
    """Attitude (w, x, y, z) of a camera in NED, as MAVLink's camera and gimbal messages give it.

    The camera's frame has x along the optical axis, y right and z down (its FRD), so a level,
    north-facing vehicle's down-looking camera (pitch -90 deg) has Euler angles (0, -90, 0).
    The mount turns ``mount_yaw_deg`` right of the body's forward axis, then
    ``mount_pitch_deg`` up (``CameraSpec``).
    """
    mount = quat_from_euler_ned_frd(0.0, np.radians(mount_pitch_deg), np.radians(mount_yaw_deg))
    return _canonical(_quat_mul_wxyz(quat_enu_flu_to_ned_frd(vehicle_q_xyzw), mount))
