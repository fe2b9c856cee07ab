"""A ``worlds.World`` built into the PyBullet scene: solids as bodies, movers following time."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pybullet as p
import pytest
from shapely.geometry import box as shapely_box

import worlds
from sitl.physics.moving_solids import MOVING_SOLIDS_HZ
from sitl.vehicles.multirotor import load_airframe
from sitl.world import World, WorldConfig
from worlds.examples import example_path

DIV = 25  # physics steps per HC-SR04 reading at 500 Hz physics and 20 Hz


def _hand_made(*solids: worlds.Solid) -> worlds.World:
    """A 100 m ground world holding only ``solids``."""
    surface = worlds.Surface("ground", (0.4, 0.5, 0.3, 1.0), "grass", 1.0, 0.2)
    return worlds.World(
        kind="test",
        seed=0,
        size_m=(100.0, 100.0),
        boundary=shapely_box(-50.0, -50.0, 50.0, 50.0),
        surface=surface,
        solids=tuple(solids),
    )


def _forward_readings(world: World, n: int) -> np.ndarray:
    """n readings of vehicle 0's forward rangefinder (id 0) at its spawn pose."""
    truth = world.truth
    rot = np.array(
        [np.reshape(p.getMatrixFromQuaternion(q.tolist()), (3, 3)) for q in truth.quaternion_xyzw]
    )
    out = []
    for k in range(n):
        r = world.rangefinders.sample(k * DIV, k, truth.position_enu_m, rot)
        out.append(r.distance_m[[s.id for s in r.specs].index(0)])
    return np.array(out)


def _forward_mount_m() -> float:
    return load_airframe("typhoon_h480").rangefinders[0].position_frd_m[0]


@pytest.mark.parametrize("kind", ["offshore", "arena_aco"])
def test_an_example_world_becomes_one_fixed_body_per_solid(kind):
    scene = worlds.build(worlds.load_world(example_path(kind)))
    assert scene.solids
    with World(WorldConfig(scene=scene)) as world:
        client = world._scene.client_id
        assert len(world.obstacle_ids) == len(scene.solids)
        targets = [t for t in scene.targets if isinstance(t, worlds.OilSpill | worlds.Person)]
        bodies = 2 + len(scene.solids) + len(targets)  # vehicle, ground, solids, spills, people
        assert p.getNumBodies(physicsClientId=client) == bodies
        for body, solid in zip(world.obstacle_ids, scene.solids, strict=True):
            position, _ = p.getBasePositionAndOrientation(body, physicsClientId=client)
            assert np.allclose(position, solid.center_enu_m, atol=1e-9)
            shape = p.getCollisionShapeData(body, -1, physicsClientId=client)[0]
            if solid.shape == "cylinder":
                assert shape[2] == p.GEOM_CYLINDER
                height, radius = shape[3][0], shape[3][1]
                assert height == pytest.approx(solid.size_m[2])
                assert radius == pytest.approx(solid.size_m[0] / 2.0)
            else:
                assert shape[2] == p.GEOM_BOX
                assert np.allclose(shape[3], solid.size_m)


def test_a_rangefinder_reads_a_box_of_the_scene_within_the_noise():
    """Forward sensor, the face of a scene box 2 m from its mount: mean 2 m within the noise."""
    face_y = _forward_mount_m() + 2.0
    wall = worlds.Solid("wall", "box", (0.0, face_y + 0.1, 1.5), (10.0, 0.2, 3.0))
    config = WorldConfig(spawn_altitude_m=1.5, scene=_hand_made(wall), rangefinders=True)
    with World(config) as world:
        spec = world.airframe.rangefinders[0]
        readings = _forward_readings(world, 400)
    echo = readings[np.isfinite(readings)]
    assert len(echo) > 350
    assert abs(echo.mean() - 2.0) < 4.0 * spec.noise_sigma_at(2.0) / math.sqrt(len(echo))


@pytest.mark.parametrize("diameter_m", [0.4, 1.6])
def test_a_cylinder_is_hit_where_its_radius_says(diameter_m):
    """A cylinder centred 3 m ahead on the beam's axis reads 3 m minus its radius."""
    center_y = _forward_mount_m() + 3.0
    post = worlds.Solid("post", "cylinder", (0.0, center_y, 1.5), (diameter_m, diameter_m, 3.0))
    config = WorldConfig(spawn_altitude_m=1.5, scene=_hand_made(post), rangefinders=True)
    with World(config) as world:
        readings = _forward_readings(world, 60)
    echo = readings[np.isfinite(readings)]
    assert len(echo) >= 50
    assert abs(np.median(echo) - (3.0 - diameter_m / 2.0)) < 0.05


def test_a_moving_solid_follows_its_motion_as_the_world_steps():
    motion = worlds.SolidMotion(
        velocity_xy_m_s=(4.0, -1.5),
        bounds_xy_m=(10.0, 10.0, 20.0, 30.0),
        vertical_amplitude_m=1.0,
        vertical_period_s=2.0,
    )
    mover = worlds.Solid("mover", "box", (12.0, 20.0, 5.0), (1.0, 2.0, 1.0), 30.0, motion=motion)
    still = worlds.Solid("still", "cylinder", (-10.0, 10.0, 2.0), (1.0, 1.0, 4.0))
    with World(WorldConfig(scene=_hand_made(mover, still))) as world:
        client = world._scene.client_id
        mover_id, still_id = world.obstacle_ids
        update_s = 1.0 / MOVING_SOLIDS_HZ
        for _ in range(round(3.05 * world.config.physics_hz)):  # past a wall reflection
            world.step()
        last_update_s = math.floor(world.time_s / update_s + 1e-9) * update_s
        position, orientation = p.getBasePositionAndOrientation(mover_id, physicsClientId=client)
        assert np.allclose(position, mover.center_at(last_update_s), atol=1e-9)
        assert not np.allclose(position, mover.center_enu_m, atol=0.5)
        assert p.getEulerFromQuaternion(orientation)[2] == pytest.approx(math.radians(30.0))
        still_position, _ = p.getBasePositionAndOrientation(still_id, physicsClientId=client)
        assert np.allclose(still_position, still.center_enu_m)


def _run(config: WorldConfig, steps: int) -> tuple[np.ndarray, list[bytes]]:
    """Truth position and the packed HIL_SENSOR messages after ``steps`` resting steps."""
    packed = []
    with World(config) as world:
        for _ in range(steps):
            world.step()
            sensors, _ = world.poll_sensors()
            if sensors:
                packed.extend(m.get_payload() for m in sensors)
        return world.truth.position_enu_m.copy(), packed


def test_without_a_scene_nothing_changes_and_a_far_scene_draws_no_random_numbers():
    """scene=None adds no bodies; a far scene leaves truth and sensors as they were."""
    with World(WorldConfig(seed=3)) as world:
        assert world.obstacle_ids == []
    far = _hand_made(worlds.Solid("far", "box", (40.0, 40.0, 2.0), (2.0, 2.0, 4.0)))
    bare_truth, bare_sensors = _run(WorldConfig(seed=3), 200)
    scene_truth, scene_sensors = _run(WorldConfig(seed=3, scene=far), 200)
    assert bare_sensors and bare_sensors == scene_sensors
    assert np.array_equal(bare_truth, scene_truth)


def test_a_scene_must_be_a_worlds_world():
    with pytest.raises(ValueError, match="scene"):
        WorldConfig(scene="offshore")  # type: ignore[arg-type]


def test_the_down_camera_sees_the_scene_surface_colour():
    """Over a sea-blue surface the down camera's mean colour is the surface's, not grass."""
    sea = worlds.Surface("sea", (0.05, 0.22, 0.35, 1.0), "waves", 8.0, 0.3)
    scene = dataclasses.replace(_hand_made(), surface=sea)
    with World(WorldConfig(cameras=True, spawn_altitude_m=10.0, scene=scene)) as world:
        frames = None
        while frames is None:
            world.step()
            frames = world.poll_cameras()
    mean_rgb = frames[0].rgb.reshape(-1, 3).mean(axis=0)
    assert mean_rgb[2] > mean_rgb[1] > mean_rgb[0]
    assert np.allclose(mean_rgb, 255.0 * np.array(sea.rgba[:3]), atol=12.0)
