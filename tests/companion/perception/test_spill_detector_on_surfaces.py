"""The spill detector on the worlds' textured ground as the simulator renders it.

Over the offshore sea, from 10 m to 120 m up and tilted as a flying vehicle is, the detector
finds nothing; the offshore world's own oil spill, raised as it appears, is still found where it
lies. Over the other surfaces (asphalt, concrete, grass) the ground itself gives no detection
either (their buildings and walls are not the detector's business: it runs over the sea).
"""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Point

import worlds
from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_euler
from companion.perception.spill_detector import detect_spills, find_blobs
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.world import World, WorldConfig
from worlds.examples import example_path

SPEC = CameraSpec(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))
MODEL = CameraModel(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))
ALTITUDES_M = (10.0, 20.0, 30.0, 45.0, 60.0, 90.0, 120.0)
ATTITUDES_DEG = ((0.0, 0.0, 0.0), (5.0, -8.0, 40.0), (-10.0, 6.0, 200.0))


def _world(kind: str) -> worlds.World:
    return worlds.build(worlds.load_world(example_path(kind)))


@pytest.fixture(scope="module")
def offshore() -> worlds.World:
    return _world("offshore")


def _open_sea_points(world: worlds.World, n: int, clear_m: float) -> list[np.ndarray]:
    """n points of the sea at least ``clear_m`` from every solid and spill, seeded."""
    rng = np.random.default_rng(11)
    (x0, y0, x1, y1) = world.boundary.bounds
    obstacles = [s.footprint_at(0.0) for s in world.solids]
    obstacles += [t.polygon for t in world.targets_of(worlds.OilSpill)]
    points: list[np.ndarray] = []
    while len(points) < n:
        xy = rng.uniform((x0, y0), (x1, y1))
        here = Point(*xy)
        if world.boundary.contains(here) and all(o.distance(here) > clear_m for o in obstacles):
            points.append(xy)
    return points


def test_the_sea_alone_gives_no_spill_from_10_to_120_m(offshore):
    with World(WorldConfig(cameras=True, camera=SPEC, scene=offshore)) as sim:
        rig = sim._cameras
        frames = 0
        for k, xy in enumerate(_open_sea_points(offshore, len(ALTITUDES_M), 150.0)):
            for euler in ATTITUDES_DEG:
                body = np.array([*xy, ALTITUDES_M[k]])
                rotation = rotation_flu_enu_from_euler(*euler)
                centre, axes = camera_pose_enu(SPEC, body, rotation)
                rgb = rig.render_camera(0, centre, axes)
                assert find_blobs(rgb) == [], (ALTITUDES_M[k], euler)
                # Far from it: the darkest pixel's brightest channel is well above oil's 28.
                assert rgb.max(axis=-1).min() > 40
                frames += 1
    assert frames == len(ALTITUDES_M) * len(ATTITUDES_DEG)


@pytest.mark.parametrize("altitude_m", [15.0, 40.0, 80.0])
def test_the_world_spill_on_the_sea_is_still_found(offshore, altitude_m):
    spill = offshore.targets_of(worlds.OilSpill)[0]
    cx, cy = spill.polygon.centroid.coords[0]
    body = np.array([cx + 2.0, cy - 1.5, altitude_m])
    rotation = rotation_flu_enu_from_euler(3.0, -4.0, 75.0)
    with World(WorldConfig(cameras=True, camera=SPEC, scene=offshore)) as sim:
        sim._spills.update(spill.appear_s)
        centre, axes = camera_pose_enu(SPEC, body, rotation)
        rgb = sim._cameras.render_camera(0, centre, axes)
    [d] = detect_spills(rgb, MODEL, body, rotation)
    assert np.hypot(d.position_enu_m[0] - cx, d.position_enu_m[1] - cy) < 0.1 * altitude_m
    assert d.radius_m == pytest.approx(np.sqrt(spill.polygon.area / np.pi), rel=0.3)


@pytest.mark.parametrize("kind", ["city", "indoor", "arena_aco", "workspace_mco", "taskmap"])
def test_no_other_surface_looks_like_oil(kind):
    """The ground layer alone (no buildings): asphalt, concrete or grass, 10 m to 120 m."""
    with World(WorldConfig(cameras=True, camera=SPEC, scene=_world(kind))) as sim:
        layer = sim._cameras._layers[0]
        for altitude_m in ALTITUDES_M:
            for euler in ATTITUDES_DEG:
                body = np.array([13.7, -21.2, altitude_m])
                centre, axes = camera_pose_enu(SPEC, body, rotation_flu_enu_from_euler(*euler))
                rgb = layer.render(centre, axes)
                assert find_blobs(rgb) == [], (altitude_m, euler)
