"""A vehicle camera's geometry as the companion knows it: pixels <-> points on the plane z = 0.

The model is the one the simulator renders with (and a real calibrated, undistorted camera has):
a pinhole with square pixels and the principal point at the image centre, focal length
``f = (width / 2) / tan(hfov / 2)``; pixel ``(u, v)`` (u right, v down, pixel k spanning
[k, k + 1)) sees the ray ``((u - cx) / f, (v - cy) / f, 1)`` of the optical frame (x right, y
down, z forward). The mount is given in the body's FRD frame: the optical centre at
``position_frd_m`` from the centre of mass, the optical axis ``pitch_deg`` above the body's
forward axis (-90: straight down) after turning ``yaw_deg`` to its right.

Frames: the world is ENU (x east, y north, z up, m); attitudes are rotations FLU -> ENU, or the
MAVLink/MAVSDK quaternion NED -> FRD (``rotation_flu_enu_from_quaternion`` converts). Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from shapely.geometry import Polygon

_FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])
_NED_TO_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


@dataclass(frozen=True)
class CameraModel:
    """Resolution, field of view and mount of one camera."""

    width_px: int = 320
    """Image width, pixels (>= 1)."""
    height_px: int = 240
    """Image height, pixels (>= 1)."""
    hfov_deg: float = 114.59
    """Horizontal field of view, degrees in (0, 180) (the Typhoon H480's CGO3+: 2 rad)."""
    pitch_deg: float = -90.0
    """Elevation of the optical axis above the body's forward axis, degrees (-90: down)."""
    yaw_deg: float = 0.0
    """Azimuth of the optical axis to the right of the body's forward axis, degrees."""
    position_frd_m: tuple[float, float, float] = (0.16, 0.0, 0.12)
    """Optical centre from the centre of mass, body FRD, m."""

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if not -90.0 <= self.pitch_deg <= 90.0:
            raise ValueError(f"pitch_deg must be in [-90, 90], got {self.pitch_deg!r}")
        if len(self.position_frd_m) != 3:
            raise ValueError(f"position_frd_m needs 3 numbers, got {self.position_frd_m!r}")

    @property
    def focal_px(self) -> float:
        """Focal length, pixels (fx = fy)."""
        return self.width_px / 2.0 / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def principal_point_px(self) -> tuple[float, float]:
        """(cx, cy), pixels: the image centre."""
        return (self.width_px / 2.0, self.height_px / 2.0)

    def optical_to_frd(self) -> np.ndarray:
        """Rotation optical -> body FRD (3, 3): columns are the optical x, y, z axes in FRD."""
        pitch, yaw = math.radians(self.pitch_deg), math.radians(self.yaw_deg)
        z = np.array(
            [math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch)]
        )
        x = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
        return np.column_stack((x, np.cross(z, x), z))

    def pose_enu(
        self, body_position_enu_m: Sequence[float], rotation_flu_enu: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Optical centre (3,) in ENU and rotation optical -> ENU (3, 3) on a body at that pose."""
        r = np.asarray(rotation_flu_enu, dtype=float) @ _FRD_TO_FLU
        centre = np.asarray(body_position_enu_m, dtype=float) + r @ np.asarray(self.position_frd_m)
        return centre, r @ self.optical_to_frd()

    def pixels_to_ground(
        self,
        pixels_uv: np.ndarray,
        body_position_enu_m: Sequence[float],
        rotation_flu_enu: np.ndarray,
    ) -> np.ndarray:
        """Points (M, 3) on the plane z = 0 seen at pixel coordinates (M, 2); NaN rows: none.

        A ray that does not meet the plane in front of the camera (at or above the horizon, or
        a camera below the plane) gives a NaN row.
        """
        uv = np.atleast_2d(np.asarray(pixels_uv, dtype=float))
        centre, axes = self.pose_enu(body_position_enu_m, rotation_flu_enu)
        cx, cy = self.principal_point_px
        f = self.focal_px
        rays = np.column_stack(((uv[:, 0] - cx) / f, (uv[:, 1] - cy) / f, np.ones(len(uv))))
        dirs = rays @ axes.T
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -centre[2] / dirs[:, 2]
        t = np.where((t > 0.0) & np.isfinite(t) & (centre[2] > 0.0), t, np.nan)
        return centre + dirs * t[:, None]

    def ground_to_pixels(
        self,
        points_enu_m: np.ndarray,
        body_position_enu_m: Sequence[float],
        rotation_flu_enu: np.ndarray,
    ) -> np.ndarray:
        """Pixel coordinates (M, 2) of world points (M, 3); NaN rows for points behind it."""
        pts = np.atleast_2d(np.asarray(points_enu_m, dtype=float))
        centre, axes = self.pose_enu(body_position_enu_m, rotation_flu_enu)
        optical = (pts - centre) @ axes
        z = np.where(optical[:, 2] > 0.0, optical[:, 2], np.nan)
        cx, cy = self.principal_point_px
        f = self.focal_px
        return np.column_stack((f * optical[:, 0] / z + cx, f * optical[:, 1] / z + cy))

    def footprint(
        self, body_position_enu_m: Sequence[float], rotation_flu_enu: np.ndarray
    ) -> Polygon | None:
        """The image's outline on the plane z = 0 (a quadrilateral), None if a corner sees none."""
        w, h = self.width_px, self.height_px
        corners = self.pixels_to_ground(
            np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]),
            body_position_enu_m,
            rotation_flu_enu,
        )
        if not np.isfinite(corners).all():
            return None
        return Polygon(corners[:, :2])


def rotation_flu_enu_from_quaternion(w: float, x: float, y: float, z: float) -> np.ndarray:
    """Rotation FLU -> ENU (3, 3) from a MAVLink/MAVSDK attitude quaternion (NED -> FRD, w first).

    MAVSDK's ``telemetry.attitude_quaternion()`` gives the rotation of the body FRD frame in
    NED (``v_ned = R(q) v_frd``); the same rotation seen in ENU and FLU is
    ``P R(q) diag(1, -1, -1)`` with P swapping north/east and negating down.
    """
    q = np.array([w, x, y, z], dtype=float)
    norm = float(np.linalg.norm(q))
    if not norm > 0.0:
        raise ValueError(f"attitude quaternion must be non-zero, got {(w, x, y, z)}")
    w, x, y, z = q / norm
    r_ned_frd = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return _NED_TO_ENU @ r_ned_frd @ _FRD_TO_FLU


def rotation_flu_enu_from_euler(roll_deg: float, pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """Rotation FLU -> ENU from PX4-style Euler angles (FRD in NED; yaw 0 = north, clockwise)."""
    r, p, y = (math.radians(a) for a in (roll_deg, pitch_deg, yaw_deg))
    cr, sr, cp, sp, cy, sy = (
        math.cos(r),
        math.sin(r),
        math.cos(p),
        math.sin(p),
        math.cos(y),
        math.sin(y),
    )
    r_ned_frd = np.array(
        [
            [cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy],
            [cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy],
            [-sp, sr * cp, cr * cp],
        ]
    )
    return _NED_TO_ENU @ r_ned_frd @ _FRD_TO_FLU
