"""The detector on frames the simulator renders: a spill-coloured slab on the offshore sea.

Tests may import ``sitl`` (the companion code may not): the frame comes from the simulator's own
camera rig over the offshore world's textured sea, the pose from the same numbers handed to the
companion's camera model, so this checks the two camera models agree and the thresholds suit
the colours the camera really renders.
"""

from __future__ import annotations

import numpy as np
import pytest

import worlds
from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_euler
from companion.perception.spill_detector import detect_spills, find_blobs
from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.world import World, WorldConfig
from worlds.examples import example_path

SPEC = CameraSpec(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))
MODEL = CameraModel(width_px=320, height_px=240, hfov_deg=114.59, position_frd_m=(0.16, 0.0, 0.12))


@pytest.fixture(scope="module")
def offshore() -> worlds.World:
    return worlds.build(worlds.load_world(example_path("offshore")))


@pytest.mark.parametrize("euler_deg", [(0.0, 0.0, 0.0), (4.0, -6.0, 125.0)])
def test_a_rendered_spill_is_found_where_it_lies(offshore, euler_deg):
    """A 12 m x 8 m slab of the spill colour on the sea: one detection within 1 m of its centre;
    the same view without it: none (the sea's texture and grid give no false spill)."""
    spill_rgba = offshore.targets_of(worlds.OilSpill)[0].rgba
    spill_xy = np.array([-300.0, -230.0])  # open sea, away from the rig and the tanker
    slab = BoxObstacle((*spill_xy, 0.05), (12.0, 8.0, 0.1), yaw_deg=20.0, rgba=spill_rgba)
    body = np.array([-310.0, -236.0, 45.0])
    rotation = rotation_flu_enu_from_euler(*euler_deg)
    config = WorldConfig(cameras=True, camera=SPEC, scene=offshore, obstacles=(slab,))
    with World(config) as world:
        centre, axes = camera_pose_enu(SPEC, body, rotation)
        rig = world._cameras
        with_spill = rig.render_camera(0, centre, axes, force_tiny=True)
    with World(WorldConfig(cameras=True, camera=SPEC, scene=offshore)) as world:
        sea_only = world._cameras.render_camera(0, centre, axes, force_tiny=True)
    assert find_blobs(sea_only) == []
    [d] = detect_spills(with_spill, MODEL, body, rotation)
    assert np.hypot(*(np.array(d.position_enu_m[:2]) - spill_xy)) < 1.0
    assert d.radius_m == pytest.approx(np.sqrt(12.0 * 8.0 / np.pi), rel=0.15)
