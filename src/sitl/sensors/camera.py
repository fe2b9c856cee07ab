"""RGB cameras: mount, optics and rate of a vehicle's camera, its pinhole intrinsics, its frames.

Frames: the camera's optical frame has x right, y down, z forward (OpenCV's convention). The
mount is given in the vehicle's body FRD frame: ``position_frd_m`` from the centre of mass, and
the optical axis pointing ``pitch_deg`` above the body's forward axis (0: forward, -90: straight
down) after turning ``yaw_deg`` to the right of it.

Rendering is ``camera_render`` (TinyRenderer for bodies, ``camera_ground`` for the ground and
the sky); see docs/sensors.md, "Cameras".
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics of an undistorted camera, pixels (OpenCV's K matrix)."""

    width_px: int
    height_px: int
    fx_px: float
    fy_px: float
    cx_px: float
    cy_px: float

    @property
    def matrix(self) -> np.ndarray:
        """The 3x3 camera matrix K."""
        return np.array(
            [[self.fx_px, 0.0, self.cx_px], [0.0, self.fy_px, self.cy_px], [0.0, 0.0, 1.0]]
        )

    def project(self, points_optical_m: np.ndarray) -> np.ndarray:
        """Pixels (u right, v down; pixel k spans [k, k + 1)) of optical-frame points (M, 3).

        Points behind the camera (z <= 0) give NaN.
        """
        pts = np.atleast_2d(np.asarray(points_optical_m, dtype=float))
        z = np.where(pts[:, 2] > 0.0, pts[:, 2], np.nan)
        return np.column_stack(
            (self.fx_px * pts[:, 0] / z + self.cx_px, self.fy_px * pts[:, 1] / z + self.cy_px)
        )


@dataclass(frozen=True)
class CameraSpec:
    """One vehicle's camera: resolution, field of view, frame rate and mount."""

    width_px: int = 320
    """Image width, pixels, >= 1."""
    height_px: int = 240
    """Image height, pixels, >= 1."""
    hfov_deg: float = 80.0
    """Horizontal field of view, degrees, in (0, 180)."""
    rate_hz: float = 5.0
    """Frame rate, Hz, > 0; it must divide the physics rate."""
    position_frd_m: tuple[float, float, float] = (0.1, 0.0, 0.1)
    """Optical centre relative to the centre of mass, body FRD, m."""
    pitch_deg: float = -90.0
    """Elevation of the optical axis above the body's forward axis, degrees in [-90, 90]."""
    yaw_deg: float = 0.0
    """Azimuth of the optical axis to the right of the body's forward axis, degrees."""
    near_m: float = 0.05
    """Nearest rendered distance, m, > 0."""
    far_m: float = 200.0
    """Farthest rendered distance, m, > near_m."""

    def __post_init__(self) -> None:
        for name in ("width_px", "height_px"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"camera {name} must be a positive integer, got {value!r}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"camera hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0.0):
            raise ValueError(f"camera rate_hz must be positive, got {self.rate_hz!r}")
        position = tuple(float(v) for v in self.position_frd_m)
        if len(position) != 3 or not all(math.isfinite(v) for v in position):
            raise ValueError(
                f"camera position_frd_m needs 3 finite numbers, got {self.position_frd_m!r}"
            )
        object.__setattr__(self, "position_frd_m", position)
        if not -90.0 <= self.pitch_deg <= 90.0:
            raise ValueError(f"camera pitch_deg must be in [-90, 90], got {self.pitch_deg!r}")
        if not math.isfinite(self.yaw_deg):
            raise ValueError(f"camera yaw_deg must be finite, got {self.yaw_deg!r}")
        if not (0.0 < self.near_m < self.far_m and math.isfinite(self.far_m)):
            raise ValueError(
                f"camera needs 0 < near_m < far_m, got near_m={self.near_m!r}, far_m={self.far_m!r}"
            )

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view of square pixels, degrees."""
        half = math.atan(
            math.tan(math.radians(self.hfov_deg) / 2.0) * self.height_px / self.width_px
        )
        return math.degrees(2.0 * half)

    def intrinsics(self) -> CameraIntrinsics:
        """Pinhole intrinsics: square pixels, principal point at the image centre."""
        f = self.width_px / 2.0 / math.tan(math.radians(self.hfov_deg) / 2.0)
        return CameraIntrinsics(
            self.width_px, self.height_px, f, f, self.width_px / 2.0, self.height_px / 2.0
        )


@dataclass(frozen=True)
class CameraFrame:
    """One rendered image of one vehicle's camera, with the pose it was taken from."""

    vehicle: int
    """Vehicle index (0-based)."""
    time_s: float
    """Simulation time of the exposure, s."""
    rgb: np.ndarray
    """Image, (height_px, width_px, 3) uint8, RGB, row 0 at the top."""
    position_enu_m: np.ndarray
    """Optical centre in the world, ENU, m, (3,)."""
    vehicle_quaternion_xyzw: np.ndarray
    """Attitude of the vehicle body (FLU -> ENU) at the exposure, (x, y, z, w)."""
    spec: CameraSpec
    """The camera that took it."""


MOUNT_PITCH_DEG = {"down": -90.0, "forward": 0.0}
"""Mount presets: pitch of the optical axis, degrees ("down": outdoor survey, "forward": indoor)."""

RENDER_S_PER_PIXEL = 5e-8
"""Rough cost per pixel of a frame with some vehicle or obstacle in view, s: the ground is drawn
per pixel ray (about 0.7 ms at 320x240), TinyRenderer adds about 3 ms at 320x240 and 200 ns
per pixel its bodies cover (``benchmarks/camera_frames.py``). For load estimates, not a
guarantee: frames with no other body in view cost about a fifth of it."""

SKY_RGB = (135, 185, 235)
"""Colour of every pixel that sees nothing (the sky), RGB."""

_FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


def with_mount(spec: CameraSpec, mount: str) -> CameraSpec:
    """``spec`` pointed by a preset: "down" (pitch -90 deg) or "forward" (pitch 0), yaw 0."""
    if mount not in MOUNT_PITCH_DEG:
        raise ValueError(f"camera mount must be one of {sorted(MOUNT_PITCH_DEG)}, got {mount!r}")
    return dataclasses.replace(spec, pitch_deg=MOUNT_PITCH_DEG[mount], yaw_deg=0.0)


def optical_axes_frd(spec: CameraSpec) -> np.ndarray:
    """Rotation optical -> body FRD (3, 3): columns are the optical x, y, z axes in FRD."""
    pitch, yaw = math.radians(spec.pitch_deg), math.radians(spec.yaw_deg)
    cp = math.cos(pitch)
    z = np.array([cp * math.cos(yaw), cp * math.sin(yaw), -math.sin(pitch)])
    x = np.array([-math.sin(yaw), math.cos(yaw), 0.0])
    return np.column_stack((x, np.cross(z, x), z))


def camera_pose_enu(
    spec: CameraSpec, body_position_enu_m: np.ndarray, body_rotation_flu_enu: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Optical centre (3,) in ENU and rotation optical -> ENU (3, 3) of a camera on a body.

    Args:
        spec: the camera and its mount.
        body_position_enu_m: centre of mass, ENU, m.
        body_rotation_flu_enu: attitude, ``v_enu = R @ v_flu``.
    """
    to_flu = _FRD_TO_FLU
    centre = body_position_enu_m + body_rotation_flu_enu @ (to_flu @ spec.position_frd_m)
    return centre, body_rotation_flu_enu @ to_flu @ optical_axes_frd(spec)
