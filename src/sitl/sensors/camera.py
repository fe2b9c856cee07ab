"""RGB cameras: mount, optics and rate of a vehicle's camera, its pinhole intrinsics, its frames.

Frames: the camera's optical frame has x right, y down, z forward (OpenCV's convention). The
mount is given in the vehicle's body FRD frame: ``position_frd_m`` from the centre of mass, and
the optical axis pointing ``pitch_deg`` above the body's forward axis (0: forward, -90: straight
down) after turning ``yaw_deg`` to the right of it.

Rendering: the flat textured ground and the sky per pixel ray (``camera_ground``), and over
them PyBullet's TinyRenderer (software, no OpenGL context) image of the vehicles and obstacles
where its depth buffer is nearer than the ground; TinyRenderer runs only when some body's
bounding box meets the view frustum. Its view matrix comes from the vehicle's pose and the
mount, its projection matrix from ``CameraSpec.intrinsics`` (so a point lands on the pixel
``CameraIntrinsics.project`` predicts, pixels sampled at their centres); see docs/sensors.md,
"Cameras".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import pybullet as p

from sitl.clock import rate_divisor
from sitl.sensors.camera_ground import GroundLayer


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

_SKY_DEPTH = np.nextafter(np.float32(1.0), np.float32(0.0))  # TinyRenderer clears to this or 1
_FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])
_OPTICAL_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])  # OpenGL eye: x right, y up, looking along -z


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


def view_matrix(centre_enu_m: np.ndarray, optical_to_enu: np.ndarray) -> list[float]:
    """PyBullet (OpenGL, column-major) view matrix of a camera at that pose."""
    world_to_optical = np.eye(4)
    world_to_optical[:3, :3] = optical_to_enu.T
    world_to_optical[:3, 3] = -optical_to_enu.T @ centre_enu_m
    return (_OPTICAL_TO_GL @ world_to_optical).flatten(order="F").tolist()


def projection_matrix(spec: CameraSpec) -> list[float]:
    """PyBullet (OpenGL, column-major) projection matrix of the spec's pinhole intrinsics.

    A point of the optical frame lands on the pixel ``spec.intrinsics().project`` gives (image
    row 0 at the top, as ``getCameraImage`` returns it); depth is clipped to [near_m, far_m].
    TinyRenderer samples pixel (u, v) at the point (u, v + 1) of the image its matrix maps to
    (pixel centres at integer coordinates of its y-up screen); the principal point handed to it
    is shifted by half a pixel so that it samples K's pixel centres (u + 0.5, v + 0.5).
    """
    k = spec.intrinsics()
    w, h, n, f = k.width_px, k.height_px, spec.near_m, spec.far_m
    cx, cy = k.cx_px - 0.5, k.cy_px + 0.5
    proj = np.array(
        [
            [2.0 * k.fx_px / w, 0.0, 1.0 - 2.0 * cx / w, 0.0],
            [0.0, 2.0 * k.fy_px / h, 2.0 * cy / h - 1.0, 0.0],
            [0.0, 0.0, -(f + n) / (f - n), -2.0 * f * n / (f - n)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )
    return proj.flatten(order="F").tolist()


def _tiny_render(
    client_id: int,
    spec: CameraSpec,
    centre_enu_m: np.ndarray,
    optical_to_enu: np.ndarray,
    segmentation: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """TinyRenderer's RGBA (H, W, 4) uint8, OpenGL depth (H, W) float32 and body ids if asked."""
    flags = 0 if segmentation else p.ER_NO_SEGMENTATION_MASK
    _, _, rgba, depth, seg = p.getCameraImage(
        spec.width_px,
        spec.height_px,
        view_matrix(centre_enu_m, optical_to_enu),
        projection_matrix(spec),
        renderer=p.ER_TINY_RENDERER,
        flags=flags,
        physicsClientId=client_id,
    )
    shape = (spec.height_px, spec.width_px)
    return (
        np.asarray(rgba, dtype=np.uint8).reshape(*shape, 4),
        np.asarray(depth, dtype=np.float32).reshape(shape),
        np.asarray(seg).reshape(shape) if segmentation else None,
    )


def render(
    client_id: int,
    spec: CameraSpec,
    centre_enu_m: np.ndarray,
    optical_to_enu: np.ndarray,
    segmentation: bool = False,
) -> tuple[np.ndarray, np.ndarray | None]:
    """TinyRenderer's image alone: RGB (H, W, 3) uint8, and body ids if asked.

    It holds the bodies PyBullet draws (vehicles, obstacles) but not the ground, which the
    cameras draw themselves (``CameraRig.render_camera`` composites both). Pixels that see
    nothing get ``SKY_RGB``. The segmentation (H, W) holds each pixel's PyBullet body id (-1:
    nothing); it costs extra, so frames are rendered without it.
    """
    rgba, depth, seg = _tiny_render(client_id, spec, centre_enu_m, optical_to_enu, segmentation)
    rgb = rgba[:, :, :3].copy()
    rgb[depth >= _SKY_DEPTH] = SKY_RGB
    return rgb, seg


def view_frustum_planes(spec: CameraSpec) -> tuple[float, float, float, float]:
    """Bounds of x/z and y/z (optical frame) of what a frame may show, one pixel of margin.

    The pixels are sampled at their centres (``projection_matrix``), spanning [0.5, W - 0.5]
    and [0.5, H - 0.5]; returns (x_min, x_max, y_min, y_max).
    """
    k = spec.intrinsics()
    return (
        (-0.5 - k.cx_px) / k.fx_px,
        (k.width_px + 0.5 - k.cx_px) / k.fx_px,
        (-0.5 - k.cy_px) / k.fy_px,
        (k.height_px + 0.5 - k.cy_px) / k.fy_px,
    )


_BOX_CORNERS = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=bool)


def boxes_in_view(
    spec: CameraSpec,
    centre_enu_m: np.ndarray,
    optical_to_enu: np.ndarray,
    aabb_min_enu_m: np.ndarray,
    aabb_max_enu_m: np.ndarray,
) -> bool:
    """Whether any of the world-aligned boxes (M, 3) may show in the camera's view.

    False only if every box lies entirely outside one plane of the view frustum (left, right,
    top, bottom, near, far): then TinyRenderer draws none of their pixels. Conservative: True
    may still mean nothing visible.
    """
    if len(aabb_min_enu_m) == 0:
        return False
    corners = np.where(_BOX_CORNERS, aabb_max_enu_m[:, None, :], aabb_min_enu_m[:, None, :])
    optical = (corners - centre_enu_m) @ optical_to_enu  # (M, 8, 3): R^T (p - c) per corner
    x, y, z = optical[..., 0], optical[..., 1], optical[..., 2]
    x_min, x_max, y_min, y_max = view_frustum_planes(spec)
    outside = (
        (x < x_min * z).all(axis=1)
        | (x > x_max * z).all(axis=1)
        | (y < y_min * z).all(axis=1)
        | (y > y_max * z).all(axis=1)
        | (z < spec.near_m).all(axis=1)
        | (z > spec.far_m).all(axis=1)
    )
    return not bool(outside.all())


_BOX_MARGIN_M = 0.01  # added around each body's bounds (rounding of visuals' frames)


def _visual_corners_local(client_id: int, body: int) -> np.ndarray:
    """Corners (K, 3) of boxes bounding each visual shape of a body, in its base frame, m.

    Boxes, cylinders, capsules and spheres are bounded exactly; anything else (meshes, planes,
    bodies with links) gives infinite corners; a body without visual shapes none (K = 0).
    """
    if p.getNumJoints(body, physicsClientId=client_id) > 0:
        return np.full((1, 3), np.inf)
    inertial_offset = np.linalg.norm(
        p.getDynamicsInfo(body, -1, physicsClientId=client_id)[3]
    )  # visuals' frames are given from the inertial frame; bound the difference
    corners = []
    for shape in p.getVisualShapeData(body, physicsClientId=client_id):
        geometry, dims, position, orientation = shape[2], shape[3], shape[5], shape[6]
        if geometry == p.GEOM_BOX:
            half = np.asarray(dims[:3]) / 2.0
        elif geometry == p.GEOM_CYLINDER:
            half = np.array([dims[1], dims[1], dims[0] / 2.0])
        elif geometry == p.GEOM_CAPSULE:
            half = np.array([dims[1], dims[1], dims[0] / 2.0 + dims[1]])
        elif geometry == p.GEOM_SPHERE:
            half = np.full(3, dims[0])
        else:
            return np.full((1, 3), np.inf)
        half = half + inertial_offset
        rotation = np.reshape(p.getMatrixFromQuaternion(orientation), (3, 3))
        local = np.where(_BOX_CORNERS, half, -half)
        corners.append(local @ rotation.T + position)
    if not corners:
        return np.zeros((0, 3))
    return np.concatenate(corners)


class CameraRig:
    """Every vehicle's camera in one PyBullet scene, rendered only when due at its rate.

    A frame is the ground and sky computed per pixel ray (``camera_ground.GroundLayer``, about
    1 ms at 320x240) with TinyRenderer's image of the vehicles and obstacles composited over it
    where its depth buffer is nearer than the ground. TinyRenderer (about 3 ms for an empty
    320x240 frame, plus about 200 ns per pixel covered) runs only when some other body's
    bounding box meets the camera's view frustum; the camera's own vehicle never shows (checked
    at load) and is left out of that test. The rig does nothing at the steps between frames but
    one integer test.

    Args:
        client_id: the PyBullet client holding the scene.
        specs: each vehicle's camera, None for none.
        physics_hz: physics rate (each camera's rate must divide it).
        ground_texture_rgb: one tile of ground (S, S, 3) uint8 RGB.
        tile_m: the square of ground one tile covers, m.
        ground_id: PyBullet body id of the ground (its collision plane; never drawn).
        vehicle_ids: PyBullet body id of each vehicle, in vehicle order.
    """

    def __init__(
        self,
        client_id: int,
        specs: Sequence[CameraSpec | None],
        physics_hz: float,
        ground_texture_rgb: np.ndarray,
        tile_m: float,
        ground_id: int,
        vehicle_ids: Sequence[int],
    ) -> None:
        self.client_id = client_id
        self.specs: tuple[CameraSpec | None, ...] = tuple(specs)
        """Each vehicle's camera, None for a vehicle without one."""
        if len(vehicle_ids) != len(self.specs):
            raise ValueError(f"{len(vehicle_ids)} vehicle ids for {len(self.specs)} cameras")
        self._cameras = [
            (i, spec, rate_divisor(physics_hz, spec.rate_hz, "camera rate_hz"))
            for i, spec in enumerate(self.specs)
            if spec is not None
        ]
        self._every = math.gcd(*(divisor for _, _, divisor in self._cameras))
        self.ground_texture_rgb = np.array(ground_texture_rgb, dtype=np.uint8)
        """The tile of ground the cameras see, (S, S, 3) RGB, repeating every ``tile_m``."""
        self.ground_texture_rgb.flags.writeable = False
        self.tile_m = tile_m
        """Side of the square of ground one tile covers, m."""
        self._layers = {
            i: GroundLayer(spec, ground_texture_rgb, tile_m, SKY_RGB)
            for i, spec, _ in self._cameras
        }
        self._ground_id = ground_id
        self._vehicle_ids = tuple(vehicle_ids)
        self._visual_corners: dict[int, np.ndarray] = {}
        self.tiny_renders = 0
        """How many frames needed TinyRenderer (some body in view), for diagnostics."""

    def due(self, tick: int) -> bool:
        """Whether any camera takes a frame at this physics step."""
        return bool(self._every) and tick % self._every == 0

    def body_boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Body ids (M,) and world AABBs (M, 3) min and max of what TinyRenderer draws of each.

        The boxes bound the bodies' visual shapes (a vehicle's rotor discs are visual only, so
        its collision AABB would not do); the ground is left out (never drawn). A body whose
        visuals cannot be bounded (meshes, links) gets an infinite box: always rendered.
        """
        cid = self.client_id
        ids, lows, highs = [], [], []
        for k in range(p.getNumBodies(physicsClientId=cid)):
            body = p.getBodyUniqueId(k, physicsClientId=cid)
            if body == self._ground_id:
                continue
            corners = self._visual_corners.get(body)
            if corners is None:
                corners = self._visual_corners[body] = _visual_corners_local(cid, body)
            ids.append(body)
            if len(corners) == 0:  # no visual shape: PyBullet draws the collision shapes
                low, high = p.getAABB(body, -1, physicsClientId=cid)
                lows.append(np.asarray(low) - _BOX_MARGIN_M)
                highs.append(np.asarray(high) + _BOX_MARGIN_M)
                continue
            if not np.isfinite(corners).all():
                lows.append(np.full(3, -np.inf))
                highs.append(np.full(3, np.inf))
                continue
            position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=cid)
            rotation = np.reshape(p.getMatrixFromQuaternion(orientation), (3, 3))
            world = corners @ rotation.T + position
            lows.append(world.min(axis=0) - _BOX_MARGIN_M)
            highs.append(world.max(axis=0) + _BOX_MARGIN_M)
        if not ids:
            return np.zeros(0, dtype=int), np.zeros((0, 3)), np.zeros((0, 3))
        return np.asarray(ids, dtype=int), np.asarray(lows), np.asarray(highs)

    def render_camera(
        self,
        i: int,
        centre_enu_m: np.ndarray,
        optical_to_enu: np.ndarray,
        boxes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
        force_tiny: bool = False,
        on_own_vehicle: bool = False,
    ) -> np.ndarray:
        """Vehicle i's camera image from that camera pose: a new (H, W, 3) uint8 RGB array.

        Args:
            i: vehicle index (it must have a camera).
            centre_enu_m: optical centre, ENU, m.
            optical_to_enu: rotation optical -> ENU.
            boxes: ``body_boxes()`` if already taken at this instant (one per pass).
            force_tiny: run TinyRenderer even if no body is in view (the frame is the same).
            on_own_vehicle: the pose is that of the camera on vehicle i as it is now in the
                scene: its own body, checked at load to be out of view, is not looked for.
        """
        spec = self.specs[i]
        if spec is None:
            raise ValueError(f"vehicle {i} has no camera")
        layer = self._layers[i]
        rgb = layer.render(centre_enu_m, optical_to_enu).copy()
        ids, lo, hi = self.body_boxes() if boxes is None else boxes
        others = ids != self._vehicle_ids[i] if on_own_vehicle else np.ones(len(ids), bool)
        if not force_tiny and not boxes_in_view(
            spec, centre_enu_m, optical_to_enu, lo[others], hi[others]
        ):
            return rgb
        self.tiny_renders += 1
        rgba, depth, _ = _tiny_render(self.client_id, spec, centre_enu_m, optical_to_enu, False)
        # A body's pixel shows where TinyRenderer drew it nearer than the ground (OpenGL depth
        # of the ground's distance along the axis; none: anything TinyRenderer drew).
        n, f = spec.near_m, spec.far_m
        nearer = layer.nearer_than_ground(depth, n, f, _SKY_DEPTH)
        cv2.copyTo(cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB), nearer, rgb)  # in place (~0.04 ms)
        return rgb

    def render_due(
        self,
        tick: int,
        time_s: float,
        positions_enu_m: np.ndarray,
        rotations_flu_enu: np.ndarray,
        quaternions_xyzw: np.ndarray,
    ) -> list[CameraFrame]:
        """The frames of every camera due at ``tick``, in vehicle order (one pass)."""
        frames = []
        boxes = None
        for i, spec, divisor in self._cameras:
            if tick % divisor:
                continue
            if boxes is None:
                boxes = self.body_boxes()
            centre, axes = camera_pose_enu(spec, positions_enu_m[i], rotations_flu_enu[i])
            rgb = self.render_camera(i, centre, axes, boxes, on_own_vehicle=True)
            frames.append(CameraFrame(i, time_s, rgb, centre, quaternions_xyzw[i].copy(), spec))
        return frames

    def visible_bodies(
        self, i: int, position_enu_m: np.ndarray, rotation_flu_enu: np.ndarray
    ) -> np.ndarray:
        """PyBullet body ids vehicle i's camera sees from that pose (a render with segmentation).

        The ground is not among them (TinyRenderer does not draw it).
        """
        spec = self.specs[i]
        if spec is None:
            raise ValueError(f"vehicle {i} has no camera")
        centre, axes = camera_pose_enu(spec, position_enu_m, rotation_flu_enu)
        _, seg = render(self.client_id, spec, centre, axes, segmentation=True)
        assert seg is not None
        return np.unique(seg[seg >= 0])
