"""RGB images of the project's scenes through the simulator's own cameras (codec training data).

``render_images(split, count, width, height, seed)`` yields ``(rgb, ImageInfo)`` pairs: one
camera placed at a drawn pose in a built ``worlds`` world and rendered with ``sitl``'s pipeline
(``camera_ground.GroundLayer`` for the sea or ground, TinyRenderer for the solids, people and
oil spills, composited by ``camera_render.CameraRig``). No vehicle, autopilot or MAVLink: each
world instance is one PyBullet DIRECT client holding only the scene (``_SceneCamera``), reused
for all its frames.

The mix: about 40 % offshore (down-looking, 10-120 m, most frames aimed near an oil spill that
has appeared by the frame's time), 30 % city roofs (down-looking, above the buildings), 20 %
indoor plant (forward-looking at 1-3 m), 10 % land (grass arenas and a concrete yard,
down-looking). Each frame draws its position, height, heading, a small camera tilt, the time
(spills appear, arena drums move), the TinyRenderer light and an exposure; each world instance
a ground brightness and a little variation of its surface.

The ``train`` and ``heldout`` splits never share a world instance: world seeds are even for
train and odd for heldout (``world_seed``). Every draw comes from generators seeded by the
arguments, so the same arguments give the same images, bit for bit. CLI: ``python -m
harness.imagery --help`` (``harness/imagery/__main__.py``); see docs/compression.md, "Training
images".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import shapely

import worlds
from sitl.physics.bullet_import import pybullet as p
from sitl.physics.moving_solids import MovingSolids
from sitl.physics.obstacles import add_solids
from sitl.physics.spills import OilSpills, add_people
from sitl.physics.surface_texture import surface_texture
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.sensors.camera_render import CameraRig, TinyLight
from worlds.examples import example_path

SPLITS = ("train", "heldout")
"""The two disjoint sets of world instances."""
SCENES = ("offshore", "city", "indoor", "land")
"""Scene families, in the order their images come."""
SCENE_SHARE = {"offshore": 0.4, "city": 0.3, "indoor": 0.2, "land": 0.1}
"""Share of the images of each scene family."""
LAND_KINDS = ("arena_aco", "workspace_mco", "taskmap")
"""World kinds of the land family, taken in turn: grass with obstacles, open grass, concrete."""
FRAMES_PER_WORLD = 12
"""Images rendered from one world instance (one PyBullet client) before the next is built."""
OFFSHORE_ALTITUDE_M = (10.0, 120.0)
"""Height range of the offshore camera above the sea, m."""
AIMED_SHARE = {"offshore": 0.7, "city": 0.8, "land": 0.0}
"""Share of the frames aimed near something (offshore: a spill that has appeared by then; city:
a building); the rest look anywhere in the world."""
CITY_ALTITUDE_M = (25.0, 160.0)
"""Height range of the city camera above the street, m (at least ``ROOF_CLEARANCE_M`` above
every roof in view)."""
LAND_ALTITUDE_M = (8.0, 100.0)
"""Height range of the land camera over grass, m."""
CONCRETE_ALTITUDE_M = (2.0, 25.0)
"""Height range of the land camera over the concrete yard (task map), m: its slabs are 1-3 m."""
INDOOR_HEIGHT_M = (1.0, 3.0)
"""Height range of the indoor forward-looking camera above the floor, m."""
ROOF_CLEARANCE_M = 20.0
"""Least height of a down-looking camera above any solid under its footprint, m (nearer, one
roof fills the frame)."""
INDOOR_CLEARANCE_M = 0.6
"""Least distance of the indoor camera from any solid, m."""
INDOOR_VIEW_M = 2.5
"""Free line of sight the indoor camera keeps ahead of it, m (no frame of a wall at 20 cm)."""
TILT_DEG = {"down": 8.0, "forward": 12.0}
"""Largest tilt of the camera from its mount's axis (pitch and roll, each), degrees."""
HFOV_DEG = {"down": 80.0, "forward": 90.0}
"""Horizontal field of view of the down-looking and forward-looking cameras, degrees."""
TIME_RANGE_S = (0.0, 150.0)
"""Scene times drawn (spills appear over 0-120 s in the example offshore world), s."""
GROUND_GAIN = (0.8, 1.15)
"""Range of the per-world brightness factor on the ground texture."""
EXPOSURE_GAIN = (0.85, 1.15)
"""Range of the per-frame exposure factor on the whole image (sun and camera gain)."""
SUN_ELEVATION_DEG = {"down": (25.0, 85.0), "forward": (50.0, 90.0)}
"""Range of the elevation of TinyRenderer's light, outdoors (sun) and indoors (lamps), deg."""
AMBIENT = (0.45, 0.7)
"""Range of TinyRenderer's ambient coefficient (PyBullet's default 0.6)."""
DIFFUSE = (0.25, 0.5)
"""Range of TinyRenderer's diffuse coefficient (PyBullet's default 0.35)."""

_SPLIT_BIT = {"train": 0, "heldout": 1}
_WORLDS_PER_SEED = 100_000
_SCENE_KIND = {"offshore": "offshore", "city": "city", "indoor": "indoor"}


@dataclass(frozen=True)
class ImageInfo:
    """Where one rendered image comes from (a row of index.csv)."""

    index: int
    """Position of the image in the run, from 0."""
    scene: str
    """Scene family: one of ``SCENES``."""
    world: str
    """World kind (``offshore``, ``city``, ``indoor``, ``arena_aco``, ...)."""
    altitude_m: float
    """Height of the camera above the ground, sea or floor, m."""
    split: str
    """``train`` or ``heldout``."""
    seed: int
    """Seed of the world instance (disjoint between splits)."""
    time_s: float
    """Scene time of the frame (spills appeared by then are shown), s."""
    heading_deg: float
    """Heading of the camera body, degrees counter-clockwise from east."""


def world_seed(split: str, seed: int, k: int) -> int:
    """Seed of the k-th world instance of a run: even for train, odd for heldout.

    ``seed * 100000 + k`` keeps runs with other ``seed`` values apart too (k < 100000).
    """
    return 2 * (seed * _WORLDS_PER_SEED + k) + _SPLIT_BIT[split]


def scene_counts(count: int) -> dict[str, int]:
    """Images per scene family for ``count`` images: ``SCENE_SHARE``, largest remainders."""
    exact = {s: SCENE_SHARE[s] * count for s in SCENES}
    counts = {s: math.floor(v) for s, v in exact.items()}
    left = count - sum(counts.values())
    for s in sorted(SCENES, key=lambda s: (counts[s] - exact[s], SCENES.index(s)))[:left]:
        counts[s] += 1
    return counts


def _check_args(split: str, count: int, width: int, height: int, seed: int) -> None:
    if split not in SPLITS:
        raise ValueError(f"split must be one of {list(SPLITS)}, got {split!r}")
    for name, value, low in (("count", count, 0), ("width", width, 16), ("height", height, 16)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")


def render_images(
    split: str, count: int, width: int = 320, height: int = 240, seed: int = 0
) -> Iterator[tuple[np.ndarray, ImageInfo]]:
    """``count`` images (H, W, 3) uint8 RGB of the project's scenes, with where each comes from.

    Args:
        split: ``train`` or ``heldout`` (disjoint world instances).
        count: number of images, >= 0.
        width: image width, pixels, >= 16.
        height: image height, pixels, >= 16.
        seed: run seed, >= 0; another seed gives other world instances.

    Raises:
        ValueError: a bad argument, naming it.
    """
    _check_args(split, count, width, height, seed)
    index = 0
    k = 0
    land_turn = 0
    for scene, n in scene_counts(count).items():
        done = 0
        while done < n:
            frames = min(FRAMES_PER_WORLD, n - done)
            ws = world_seed(split, seed, k)
            k += 1
            kind = _SCENE_KIND.get(scene) or LAND_KINDS[land_turn % len(LAND_KINDS)]
            if scene == "land":
                land_turn += 1
            for rgb, info in _world_images(scene, kind, ws, frames, width, height, split):
                yield rgb, dataclasses.replace(info, index=index)
                index += 1
            done += frames


def build_world(kind: str, seed: int, rng: np.random.Generator) -> worlds.World:
    """The shipped example world of ``kind`` with another seed and a little colour variation."""
    spec = worlds.load_world(example_path(kind))
    data = spec.model_dump()
    data["seed"] = seed
    for key in ("sea_rgba", "ground_rgba", "floor_rgba"):
        if key in data:
            tint = rng.uniform(0.85, 1.15) * rng.uniform(0.96, 1.04, 3)  # brightness, hue
            rgb = np.clip(np.asarray(data[key][:3]) * tint, 0.0, 1.0)
            data[key] = (*rgb.tolist(), 1.0)
    if kind == "offshore":
        data["wave_length_m"] = float(rng.uniform(5.0, 12.0))
        data["spill_count"] = 40  # more spills per sea: more frames with oil in view
    if kind == "taskmap":  # a yard of 1-3 m slabs instead of a 10 m map of 0.5 m ones
        data["size_m"] = (40.0, 40.0)
        data["grid_spacing_m"] = float(rng.uniform(1.0, 3.0))
    return worlds.build(type(spec).model_validate(data))


class _SceneCamera:
    """One world's scene in its own PyBullet client, and one camera to put anywhere in it.

    The scene is what ``sitl.world.World`` adds for a ``WorldConfig.scene`` (the solids, the
    people, the oil spills), without vehicles and without the ground's collision plane (the rig
    draws the ground itself; nothing here collides or steps); the camera is a ``CameraRig``
    with a single camera (no vehicle: ids -1), rendered at arbitrary poses.
    """

    def __init__(
        self, world: worlds.World, spec: CameraSpec, rng: np.random.Generator, ground_gain: float
    ) -> None:
        self.world = world
        self.spec = spec
        cid = self._cid = p.connect(p.DIRECT)
        if cid < 0:
            raise RuntimeError("could not start a PyBullet DIRECT client")
        try:
            solid_ids = add_solids(cid, world.solids)
            movers = MovingSolids(cid, world.solids, solid_ids)
            self._movers = movers if len(movers) else None
            add_people(cid, world.targets_of(worlds.Person))
            spills = world.targets_of(worlds.OilSpill)
            self._spills = OilSpills(cid, spills) if spills else None
            texture, tile_m = surface_texture(rng, world.surface)
            lit = np.clip(texture.astype(np.float32) * ground_gain, 0.0, 255.0).astype(np.uint8)
            self._rig = CameraRig(
                cid,
                [spec],
                spec.rate_hz,
                lit,
                tile_m,
                ground_id=-1,
                vehicle_ids=[-1],
                filtered_ground=True,
            )
            if self._spills is not None:
                self._rig.bound_visuals(self._spills.visual_corners_local)
        except Exception:
            self.close()
            raise

    def set_time(self, t_s: float) -> None:
        """Move the scene to time ``t_s`` (spills only ever appear: call with rising times)."""
        if self._movers is not None:
            self._movers.update(t_s)
        if self._spills is not None:
            self._spills.update(t_s)

    def render(
        self, position_enu_m: np.ndarray, rotation_flu_enu: np.ndarray, light: TinyLight
    ) -> np.ndarray:
        """The image (H, W, 3) uint8 RGB of the camera on a body at that pose, bodies so lit."""
        centre, axes = camera_pose_enu(self.spec, position_enu_m, rotation_flu_enu)
        self._rig.light = light
        return self._rig.render_camera(0, centre, axes)

    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if self._cid >= 0:
            p.disconnect(physicsClientId=self._cid)
            self._cid = -1


def _rotation(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """Body FLU -> ENU rotation: yaw about z, then pitch about y, then roll about x (radians)."""
    cy, sy, cp, sp, cr, sr = (
        math.cos(yaw),
        math.sin(yaw),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(roll),
        math.sin(roll),
    )
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def _world_images(
    scene: str, kind: str, ws: int, frames: int, width: int, height: int, split: str
) -> Iterator[tuple[np.ndarray, ImageInfo]]:
    """``frames`` images of one world instance (seed ``ws``), in rising scene time."""
    rng = np.random.default_rng([ws, SCENES.index(scene)])
    world = build_world(kind, ws, rng)
    mount = "forward" if scene == "indoor" else "down"
    spec = CameraSpec(
        width_px=width,
        height_px=height,
        hfov_deg=HFOV_DEG[mount],
        position_frd_m=(0.0, 0.0, 0.0),
        pitch_deg=-90.0 if mount == "down" else 0.0,
        far_m=400.0 if mount == "down" else 100.0,
    )
    camera = _SceneCamera(world, spec, rng.spawn(1)[0], float(rng.uniform(*GROUND_GAIN)))
    footprints = np.array([s.footprint_at(0.0) for s in world.solids], dtype=object)
    tops = np.array([s.center_enu_m[2] + s.size_m[2] / 2.0 for s in world.solids])
    try:
        times = np.sort(rng.uniform(*TIME_RANGE_S, frames))
        for t in times.tolist():
            camera.set_time(t)
            if mount == "down":
                xy, alt = _down_pose(scene, world, rng, t, footprints, tops, spec)
                position = np.array([xy[0], xy[1], alt])
                heading = float(rng.uniform(0.0, 2.0 * math.pi))
            else:
                position, heading = _indoor_pose(rng, footprints)
                alt = float(position[2])
            tilt = math.radians(TILT_DEG[mount])
            pitch, roll = rng.uniform(-tilt, tilt, 2)
            rgb = camera.render(position, _rotation(heading, pitch, roll), _light(rng, mount))
            exposure = float(rng.uniform(*EXPOSURE_GAIN))
            rgb = np.clip(rgb.astype(np.float32) * exposure + 0.5, 0.0, 255.0).astype(np.uint8)
            info = ImageInfo(
                -1, scene, kind, round(alt, 3), split, ws, round(t, 3), math.degrees(heading)
            )
            yield rgb, info
    finally:
        camera.close()


def _light(rng: np.random.Generator, mount: str) -> TinyLight:
    """A drawn TinyRenderer light: azimuth, elevation, ambient and diffuse."""
    azimuth = rng.uniform(0.0, 2.0 * math.pi)
    elevation = math.radians(rng.uniform(*SUN_ELEVATION_DEG[mount]))
    direction = (
        math.cos(elevation) * math.cos(azimuth),
        math.cos(elevation) * math.sin(azimuth),
        math.sin(elevation),
    )
    return TinyLight(direction, float(rng.uniform(*AMBIENT)), float(rng.uniform(*DIFFUSE)))


def _down_pose(
    scene: str,
    world: worlds.World,
    rng: np.random.Generator,
    t_s: float,
    footprints: np.ndarray,
    tops: np.ndarray,
    spec: CameraSpec,
) -> tuple[tuple[float, float], float]:
    """Where a down-looking camera goes: (x, y) and height, clear of the roofs below it."""
    low, high = {
        "offshore": OFFSHORE_ALTITUDE_M,
        "city": CITY_ALTITUDE_M,
        "land": CONCRETE_ALTITUDE_M if world.kind == "taskmap" else LAND_ALTITUDE_M,
    }[scene]
    x0, y0, x1, y1 = world.bounds_xy_m
    half_fov = math.tan(math.radians(spec.hfov_deg) / 2.0)
    if scene == "offshore":
        marks = [spill.polygon.centroid.coords[0] for spill in world.spills_at(t_s)]
    else:
        marks = [solid.center_enu_m[:2] for solid in world.solids]
    aimed = bool(marks) and rng.uniform() < AIMED_SHARE[scene]
    for _ in range(100):
        alt = float(rng.uniform(low, high))
        if aimed:
            cx, cy = marks[int(rng.integers(len(marks)))]
            offset = rng.uniform(-0.35, 0.35, 2) * alt * half_fov
            xy = (float(cx + offset[0]), float(cy + offset[1]))
        else:
            xy = (float(rng.uniform(x0, x1)), float(rng.uniform(y0, y1)))
        if len(tops) == 0:
            return xy, alt
        view = shapely.Point(xy).buffer(alt * half_fov * 1.3, quad_segs=4)
        under = shapely.intersects(footprints, view)
        if not under.any() or alt >= tops[under].max() + ROOF_CLEARANCE_M:
            return xy, alt
    return xy, float(tops.max() + ROOF_CLEARANCE_M)


def _indoor_pose(rng: np.random.Generator, footprints: np.ndarray) -> tuple[np.ndarray, float]:
    """A camera position inside the plant, clear of walls and machinery, and a heading (rad).

    The heading keeps ``INDOOR_VIEW_M`` of free sight ahead (the camera faces the room).
    """
    x0, y0, x1, y1 = shapely.total_bounds(footprints)
    for _ in range(500):
        xy = rng.uniform((x0, y0), (x1, y1))
        heading = float(rng.uniform(0.0, 2.0 * math.pi))
        point = shapely.Point(xy)
        if shapely.distance(footprints, point).min() < INDOOR_CLEARANCE_M:
            continue
        ahead = xy + INDOOR_VIEW_M * np.array([math.cos(heading), math.sin(heading)])
        if not shapely.intersects(footprints, shapely.LineString([xy, ahead])).any():
            break
    return np.array([xy[0], xy[1], rng.uniform(*INDOOR_HEIGHT_M)]), heading
