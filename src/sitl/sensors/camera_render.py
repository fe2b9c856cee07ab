"""Rendering the cameras: PyBullet's TinyRenderer for the bodies over the ground drawn per ray.

A frame is the flat textured ground and the sky per pixel ray (``camera_ground``), and over them
PyBullet's TinyRenderer (software, no OpenGL context) image of the vehicles and obstacles where
its depth buffer is nearer than the ground; TinyRenderer runs only when some body's bounding box
meets the view frustum. Its view matrix comes from the vehicle's pose and the mount, its
projection matrix from ``CameraSpec.intrinsics`` (so a point lands on the pixel
``CameraIntrinsics.project`` predicts, pixels sampled at their centres); see docs/sensors.md,
"Cameras".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from sitl.clock import rate_divisor
from sitl.physics.bullet_import import pybullet as p
from sitl.sensors.camera import (
    SKY_RGB,
    CameraFrame,
    CameraSpec,
    camera_pose_enu,
)
from sitl.sensors.camera_ground import GroundLayer

_SKY_DEPTH = np.nextafter(np.float32(1.0), np.float32(0.0))  # TinyRenderer clears to this or 1
_OPTICAL_TO_GL = np.diag([1.0, -1.0, -1.0, 1.0])  # OpenGL eye: x right, y up, looking along -z


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


@dataclass(frozen=True)
class TinyLight:
    """TinyRenderer's light on the bodies it draws (the ground's shade is ``GROUND_SHADE``).

    Once a client has rendered with a light, PyBullet keeps its direction for later renders.
    """

    direction_enu: tuple[float, float, float]
    """Direction towards the light, ENU (any length but zero)."""
    ambient: float = 0.6
    """Ambient coefficient (PyBullet's default 0.6)."""
    diffuse: float = 0.35
    """Diffuse coefficient (PyBullet's default 0.35)."""
    specular: float = 0.05
    """Specular coefficient (PyBullet's default 0.05)."""

    def __post_init__(self) -> None:
        direction = tuple(float(v) for v in self.direction_enu)
        if len(direction) != 3 or not all(math.isfinite(v) for v in direction):
            raise ValueError(f"light direction_enu needs 3 finite numbers: {self.direction_enu!r}")
        if not any(direction):
            raise ValueError("light direction_enu must not be zero")
        object.__setattr__(self, "direction_enu", direction)
        for name in ("ambient", "diffuse", "specular"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"light {name} must be >= 0, got {value!r}")


def _tiny_render(
    client_id: int,
    spec: CameraSpec,
    centre_enu_m: np.ndarray,
    optical_to_enu: np.ndarray,
    segmentation: bool,
    light: TinyLight | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """TinyRenderer's RGBA (H, W, 4) uint8, OpenGL depth (H, W) float32 and body ids if asked."""
    flags = 0 if segmentation else p.ER_NO_SEGMENTATION_MASK
    lighting = {}
    if light is not None:
        lighting = {
            "lightDirection": list(light.direction_enu),
            "lightAmbientCoeff": light.ambient,
            "lightDiffuseCoeff": light.diffuse,
            "lightSpecularCoeff": light.specular,
        }
    _, _, rgba, depth, seg = p.getCameraImage(
        spec.width_px,
        spec.height_px,
        view_matrix(centre_enu_m, optical_to_enu),
        projection_matrix(spec),
        renderer=p.ER_TINY_RENDERER,
        flags=flags,
        physicsClientId=client_id,
        **lighting,
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
        filtered_ground: draw the ground from a mipmap of the tile, its level picked per frame
            by the camera's height (``camera_ground.GroundLayer``'s ``filtered``).
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
        filtered_ground: bool = False,
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
            i: GroundLayer(spec, ground_texture_rgb, tile_m, SKY_RGB, filtered_ground)
            for i, spec, _ in self._cameras
        }
        self._ground_id = ground_id
        self._vehicle_ids = tuple(vehicle_ids)
        self._visual_corners: dict[int, np.ndarray] = {}
        self.tiny_renders = 0
        """How many frames needed TinyRenderer (some body in view), for diagnostics."""
        self.light: TinyLight | None = None
        """TinyRenderer's light on the bodies; None: PyBullet's default, or the light this
        client last rendered with (PyBullet keeps it). ``harness.imagery`` sets one per frame."""

    def bound_visuals(self, corners_local: dict[int, np.ndarray]) -> None:
        """Known visual bounds of bodies PyBullet cannot bound (meshes): corners (K, 3) by body id.

        The corners are in the body's frame; without them a mesh body counts as always in view
        (TinyRenderer would run for every frame).
        """
        for body, corners in corners_local.items():
            self._visual_corners[int(body)] = np.asarray(corners, dtype=float).reshape(-1, 3)

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
        rgba, depth, _ = _tiny_render(
            self.client_id, spec, centre_enu_m, optical_to_enu, False, self.light
        )
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
