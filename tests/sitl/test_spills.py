"""Oil spills (dark visual-only patches appearing at appear_s) and people (solid cylinders)."""

from __future__ import annotations

import math

import numpy as np
import pybullet as p
import pytest
from shapely.geometry import Polygon
from shapely.geometry import box as shapely_box

import worlds
from sitl.physics.spills import PERSON_DIAMETER_M, spill_mesh
from sitl.sensors.camera import CameraSpec, camera_pose_enu
from sitl.vehicles.multirotor import load_airframe
from sitl.world import World, WorldConfig

SEA = worlds.Surface("sea", (0.05, 0.22, 0.35, 1.0), "waves", 8.0, 0.3)
APPEAR_S = 1.0


def _sea(*targets: worlds.OilSpill | worlds.Person) -> worlds.World:
    return worlds.World(
        kind="test",
        seed=0,
        size_m=(400.0, 400.0),
        boundary=shapely_box(-200.0, -200.0, 200.0, 200.0),
        surface=SEA,
        targets=tuple(targets),
    )


def _disc_spill(radius_m: float = 20.0, appear_s: float = APPEAR_S) -> worlds.OilSpill:
    angles = np.linspace(0.0, 2.0 * np.pi, 25)[:-1]
    outline = tuple((radius_m * math.cos(a), radius_m * math.sin(a)) for a in angles)
    return worlds.OilSpill("spill_0", outline, appear_s)


def _centre_patch(world: World, height_m: float) -> np.ndarray:
    """Mean RGB of the middle 40 x 40 pixels of vehicle 0's camera looking down from
    (0, 0, height_m) (the spill's centre)."""
    rig = world._cameras
    centre, axes = camera_pose_enu(rig.specs[0], np.array([0.0, 0.0, height_m]), np.eye(3))
    rgb = rig.render_camera(0, centre, axes)
    h, w = rgb.shape[:2]
    return rgb[h // 2 - 20 : h // 2 + 20, w // 2 - 20 : w // 2 + 20].reshape(-1, 3).mean(axis=0)


def _step_to(world: World, t_s: float) -> None:
    while world.time_s < t_s - 1e-9:
        world.step()


@pytest.mark.parametrize("height_m", [30.0, 120.0])
def test_a_downward_camera_sees_the_sea_before_appear_s_and_the_dark_spill_after(height_m):
    config = WorldConfig(
        spawn_enu_m=((150.0, 150.0, 0.0),),
        scene=_sea(_disc_spill()),
        cameras=True,
        camera=CameraSpec(far_m=500.0),
    )
    with World(config) as world:
        _step_to(world, 0.5)
        before = _centre_patch(world, height_m)
        renders = world._cameras.tiny_renders
        _step_to(world, APPEAR_S + 0.15)
        after = _centre_patch(world, height_m)
    # Before: the sea (blue over red), and the hidden spill costs no TinyRenderer pass.
    assert before[2] > before[0] + 20.0
    assert renders == 0
    # After: the spill's near-black, in every pixel of the patch.
    assert after.max() < 25.0
    assert before.mean() - after.mean() > 30.0


def test_a_spill_is_not_hit_by_rays_and_shows_only_from_appear_s():
    spill = _disc_spill(radius_m=5.0, appear_s=0.35)
    with World(WorldConfig(spawn_enu_m=((50.0, 50.0, 0.0),), scene=_sea(spill))) as world:
        client = world._scene.client_id
        body = world._spills.body_ids[0]
        z_hidden = p.getBasePositionAndOrientation(body, physicsClientId=client)[0][2]
        _step_to(world, 0.3)
        assert p.getBasePositionAndOrientation(body, physicsClientId=client)[0][2] == z_hidden
        _step_to(world, 0.4)
        z_shown = p.getBasePositionAndOrientation(body, physicsClientId=client)[0][2]
        hit = p.rayTest([1.0, 1.0, 10.0], [1.0, 1.0, -1.0], physicsClientId=client)[0]
    assert z_hidden < -1000.0 and 0.0 < z_shown < 0.01
    assert hit[0] == world._scene.ground_id  # the ray goes through the spill to the sea
    assert hit[3][2] == pytest.approx(0.0, abs=1e-6)


def test_the_triangulation_covers_a_concave_outline_exactly():
    outline = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (5.0, 3.0), (0.0, 10.0))
    spill = worlds.OilSpill("notch", outline, 0.0)
    vertices, indices, anchor = spill_mesh(spill)
    tris = vertices[indices].reshape(-1, 3, 3)[:, :, :2] + anchor
    area = sum(Polygon(t).area for t in tris)
    assert area == pytest.approx(Polygon(outline).area)
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert (cross > 0).all()  # counter-clockwise from above: facing up


def test_a_forward_rangefinder_reads_the_distance_to_a_person():
    """A person 3 m ahead of the forward sensor's mount reads 3 m minus the body's radius."""
    mount = load_airframe("typhoon_h480").rangefinders[0].position_frd_m[0]
    person = worlds.Person("person_0", (0.0, mount + 3.0, 0.0), height_m=1.8)
    config = WorldConfig(spawn_altitude_m=1.0, scene=_sea(person), rangefinders=True)
    with World(config) as world:
        truth = world.truth
        rot = world._scene.rotation
        readings = []
        for k in range(40):
            r = world.rangefinders.sample(k * 25, k, truth.position_enu_m, rot)
            readings.append(r.distance_m[[s.id for s in r.specs].index(0)])
        client = world._scene.client_id
        (body,) = world.person_ids
        low, high = p.getAABB(body, physicsClientId=client)
    echo = np.array(readings)[np.isfinite(readings)]
    assert len(echo) >= 30
    assert abs(np.median(echo) - (3.0 - PERSON_DIAMETER_M / 2.0)) < 0.05
    assert low[2] == pytest.approx(0.0, abs=0.02) and high[2] == pytest.approx(1.8, abs=0.02)


def test_a_vehicle_dropped_on_a_person_rests_on_its_head():
    person = worlds.Person("person_0", (0.0, 0.0, 0.0), height_m=1.7)
    config = WorldConfig(spawn_altitude_m=3.0, scene=_sea(person))
    with World(config) as world:
        _step_to(world, 2.0)
        z = world.truth.position_enu_m[0, 2]
    assert z > 1.7  # not through the person


def _sensor_payloads(config: WorldConfig, steps: int) -> list[bytes]:
    out = []
    with World(config) as world:
        for _ in range(steps):
            world.step()
            sensors, _ = world.poll_sensors()
            if sensors:
                out.extend(m.get_payload() for m in sensors)
    return out


def test_spills_and_people_draw_no_random_numbers():
    far_spill = worlds.OilSpill("s", ((60.0, 60.0), (70.0, 60.0), (65.0, 70.0)), 0.1)
    far = _sea(far_spill, worlds.Person("p", (80.0, 80.0, 0.0)))
    bare = _sensor_payloads(WorldConfig(seed=5), 150)
    assert bare and bare == _sensor_payloads(WorldConfig(seed=5, scene=far), 150)
