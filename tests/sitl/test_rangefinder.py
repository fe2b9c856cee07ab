"""Ultrasonic rangefinders against geometry: walls, poles, the ground, tilt, range and dropouts."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pybullet as p
import pytest
import yaml

from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.rangefinder import (
    RAYS_PER_SENSOR,
    RangefinderArray,
    rangefinder_from_model,
)
from sitl.vehicles.multirotor import AIRFRAME_DIR, load_airframe
from sitl.world import World, WorldConfig

DIV = 25  # physics steps per HC-SR04 reading at 500 Hz physics and 20 Hz


def _pose(world: World) -> tuple[np.ndarray, np.ndarray]:
    truth = world.truth
    rot = np.array(
        [np.reshape(p.getMatrixFromQuaternion(q.tolist()), (3, 3)) for q in truth.quaternion_xyzw]
    )
    return truth.position_enu_m, rot


def _samples(
    world: World, sensor_id: int, n: int, rotation: np.ndarray | None = None
) -> np.ndarray:
    """n readings of one sensor of vehicle 0 at the world's current pose (or ``rotation``)."""
    position, rot = _pose(world)
    if rotation is not None:
        rot = rotation[None]
    out = []
    for k in range(n):
        r = world.rangefinders.sample(k * DIV, k, position, rot)
        out.append(r.distance_m[[s.id for s in r.specs].index(sensor_id)])
    return np.array(out)


def _forward_mount_m() -> float:
    return load_airframe("typhoon_h480").rangefinders[0].position_frd_m[0]


def test_a_wall_two_metres_ahead_reads_two_metres_within_the_noise():
    """Forward sensor, wall 2 m from its mount: mean 2 m, spread as configured, ~1 % dropouts."""
    face_y = _forward_mount_m() + 2.0
    wall = BoxObstacle((0.0, face_y + 0.1, 1.5), (10.0, 0.2, 3.0))
    with World(WorldConfig(spawn_altitude_m=1.5, obstacles=(wall,), rangefinders=True)) as world:
        spec = world.airframe.rangefinders[0]
        readings = _samples(world, 0, 600)
    echo = readings[np.isfinite(readings)]
    sigma = spec.noise_sigma_at(2.0)
    assert abs(echo.mean() - 2.0) < 4.0 * sigma / math.sqrt(len(echo))
    assert 0.85 * sigma < echo.std() < 1.15 * sigma
    dropped = 1.0 - len(echo) / len(readings)
    assert dropped < spec.dropout_probability + 4 * math.sqrt(spec.dropout_probability / 600)


@pytest.mark.parametrize(("angle_deg", "seen"), [(5.0, True), (12.0, False)])
def test_a_thin_pole_is_seen_inside_the_cone_and_not_outside(angle_deg, seen):
    """A 10 cm pole 2 m ahead, 5 deg off the axis of a 15 deg beam is seen; 12 deg off is not."""
    mount_y = _forward_mount_m()
    x = 2.0 * math.tan(math.radians(angle_deg))
    pole = BoxObstacle((x, mount_y + 2.0 + 0.05, 1.5), (0.1, 0.1, 3.0))
    with World(WorldConfig(spawn_altitude_m=1.5, obstacles=(pole,), rangefinders=True)) as world:
        readings = _samples(world, 0, 40)
    if seen:
        echo = readings[np.isfinite(readings)]
        assert len(echo) >= 35
        assert abs(np.median(echo) - 2.0 / math.cos(math.radians(angle_deg))) < 0.05
    else:
        assert np.isnan(readings).all()


@pytest.mark.parametrize("height_m", [0.5, 1.0, 2.0, 4.0])
def test_the_downward_sensor_reads_the_height_above_ground(height_m):
    with World(WorldConfig(spawn_altitude_m=height_m, rangefinders=True)) as world:
        spec = world.airframe.rangefinders[6]
        assert spec.orientation == 25
        readings = _samples(world, 6, 100)
    expected = height_m - spec.position_frd_m[2]
    echo = readings[np.isfinite(readings)]
    assert abs(echo.mean() - expected) < 4.0 * spec.noise_sigma_at(expected) / math.sqrt(len(echo))


@pytest.mark.parametrize("roll_deg", [5.0, 20.0, 30.0])
def test_a_tilted_vehicle_reads_the_nearest_slant_range_in_its_cone(roll_deg):
    """Rolled by phi, the nearest ground point in a cone of half-angle a is at h / cos(phi - a)."""
    height = 2.0
    with World(WorldConfig(spawn_altitude_m=height, rangefinders=True)) as world:
        spec = world.airframe.rangefinders[6]
        c, s = math.cos(math.radians(roll_deg)), math.sin(math.radians(roll_deg))
        roll = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])  # about body x (north)
        facing_north = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
        rotation = facing_north @ roll
        readings = _samples(world, 6, 100, rotation)
    mount_flu = np.array(spec.position_frd_m) * [1.0, -1.0, -1.0]
    mount_height = height + (rotation @ mount_flu)[2]
    half = spec.beam_width_deg / 2.0
    expected = mount_height / math.cos(math.radians(max(0.0, roll_deg - half)))
    echo = readings[np.isfinite(readings)]
    assert abs(echo.mean() - expected) < 4.0 * spec.noise_sigma_at(expected) / math.sqrt(len(echo))
    if roll_deg > half:  # not the centre ray's slant range
        centre = mount_height / math.cos(math.radians(roll_deg))
        assert centre - echo.mean() > 0.01


def test_out_of_range_is_no_echo_and_a_7_m_model_still_reads_it():
    """At 6 m the HC-SR04 (4.5 m) hears nothing, the MB1240-like 7 m variant reads the ground."""
    with World(WorldConfig(spawn_altitude_m=6.0, rangefinders=True)) as world:
        assert np.isnan(_samples(world, 6, 20)).all()
        position, rot = _pose(world)
        mounts = [
            [rangefinder_from_model("mb1240", 0, 25, (0.0, 0.0, 0.0), dropout_probability=0.0)]
        ]
        far = RangefinderArray(
            world._scene.client_id, world._scene.body_ids, mounts, 500.0, np.random.default_rng(1)
        )
        r = far.sample(0, 0, position, rot)
    assert r.distance_m[0] == pytest.approx(6.0, abs=0.15)


def test_a_sensor_never_sees_its_own_vehicle():
    """Mounted above the Typhoon's left skid, looking down: the rays that hit the skid are cast
    again past it, and the reading is the ground."""
    with World(WorldConfig(spawn_altitude_m=2.0, rangefinders=True)) as world:
        position, rot = _pose(world)
        mount = (0.0, -0.143, 0.05)  # body FRD: the skid tube is at y -0.143 m, z +0.165 m
        spec = rangefinder_from_model("hc_sr04", 0, 25, mount, dropout_probability=0.0)
        array = RangefinderArray(
            world._scene.client_id,
            world._scene.body_ids,
            [[spec]],
            500.0,
            np.random.default_rng(3),
        )
        readings = [array.sample(k * DIV, 0, position, rot).distance_m[0] for k in range(50)]
    assert array.rays_cast > 50 * RAYS_PER_SENSOR  # some rays hit the skid and were re-cast
    expected = 2.0 - mount[2]
    assert abs(np.mean(readings) - expected) < 4 * spec.noise_sigma_at(expected) / math.sqrt(50)


def test_dropouts_happen_at_their_probability_and_no_echo_is_reported_out_of_range():
    with World(WorldConfig(spawn_altitude_m=1.0, rangefinders=True)) as world:
        position, rot = _pose(world)
        spec = rangefinder_from_model("hc_sr04", 3, 25, (0.0, 0.0, 0.0), dropout_probability=0.3)
        array = RangefinderArray(
            world._scene.client_id,
            world._scene.body_ids,
            [[spec]],
            500.0,
            np.random.default_rng(7),
        )
        readings = [array.sample(k * DIV, k * 50_000, position, rot) for k in range(1000)]
    from sitl.hil import distance_sensor_messages

    dropped = np.mean([np.isnan(r.distance_m[0]) for r in readings])
    assert abs(dropped - 0.3) < 4 * math.sqrt(0.3 * 0.7 / 1000)
    messages = [distance_sensor_messages(r, 1)[0][0] for r in readings]
    for r, m in zip(readings, messages, strict=True):
        assert (m.id, m.orientation, m.type) == (3, 25, 1)
        if np.isnan(r.distance_m[0]):
            assert m.current_distance > m.max_distance and m.signal_quality == 1
        else:
            assert m.min_distance <= m.current_distance <= m.max_distance
            assert m.signal_quality == 100
            assert abs(m.current_distance - 100 * r.distance_m[0]) <= 0.5


def test_world_polls_all_vehicles_at_the_sensor_rate_and_can_switch_them_off():
    config = WorldConfig(n_vehicles=3, spawn_altitude_m=1.0, rangefinders=True)
    with World(config) as world:
        due = []
        for _ in range(100):
            world.step()
            msgs = world.poll_rangefinders()
            if msgs is not None:
                due.append(world.time_s)
                assert [len(v) for v in msgs] == [7, 7, 7]
                assert len({m.id for m in msgs[0]}) == 7
                assert world.poll_rangefinders() is None  # once per instant
    assert due == pytest.approx([0.05, 0.1, 0.15, 0.2])
    for off in (WorldConfig(n_vehicles=3, rangefinders=False), WorldConfig(n_vehicles=3)):
        with World(off) as world:  # off by default
            for _ in range(100):
                world.step()
                assert world.poll_rangefinders() is None


def test_rangefinders_do_not_change_other_sensors_draws():
    def imu(rangefinders: bool) -> list[float]:
        with World(WorldConfig(spawn_altitude_m=1.0, rangefinders=rangefinders)) as world:
            out = []
            for _ in range(60):
                world.step()
                world.poll_rangefinders()
                sensors, _ = world.poll_sensors()
                if sensors:
                    out.append(sensors[0].xacc)
            return out

    assert imu(True) == imu(False)


def _airframe_with(tmp_path: Path, edit) -> Path:
    folder = tmp_path / "x500"
    shutil.copytree(AIRFRAME_DIR / "x500", folder)
    path = folder / "x500.yaml"
    data = yaml.safe_load(path.read_text())
    edit(data["rangefinders"])
    path.write_text(yaml.safe_dump(data))
    return folder


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (lambda rf: rf["sensors"][2].update(x_m=0.5), ["sensors[2]", "position_frd_m", "outside"]),
        (lambda rf: rf["sensors"][1].update(orientation=9), ["sensors[1]", "orientation"]),
        (lambda rf: rf["sensors"][0].update(min_range_m=5.0), ["sensors[0]", "min_range_m"]),
        (lambda rf: rf.update(model="lidar"), ["sensors[0]", "model"]),
        (lambda rf: rf["sensors"][3].update(id=0), ["sensors[3]", "id 0"]),
        (lambda rf: rf["sensors"][4].update(range_m=3.0), ["sensors[4]", "range_m"]),
        (lambda rf: rf["sensors"][5].pop("z_m"), ["sensors[5]", "z_m"]),
    ],
)
def test_bad_rangefinder_mounts_name_the_sensor_and_field(tmp_path, edit, words):
    folder = _airframe_with(tmp_path, edit)
    with pytest.raises(ValueError) as info:
        load_airframe(folder)
    for word in ["x500.yaml", "rangefinders", *words]:
        assert word in str(info.value)


@pytest.mark.parametrize("rate_hz", [30.0, 1000.0])
def test_a_rate_that_does_not_divide_physics_fails_naming_the_sensor(tmp_path, rate_hz):
    folder = _airframe_with(tmp_path, lambda rf: rf["sensors"][6].update(rate_hz=rate_hz))
    with pytest.raises(ValueError, match=r"rangefinder id 6 rate_hz"):
        World(WorldConfig(airframe=str(folder), rangefinders=True))


def test_an_airframe_without_the_section_has_no_rangefinders(tmp_path):
    folder = tmp_path / "x500"
    shutil.copytree(AIRFRAME_DIR / "x500", folder)
    path = folder / "x500.yaml"
    data = yaml.safe_load(path.read_text())
    del data["rangefinders"]
    path.write_text(yaml.safe_dump(data))
    assert load_airframe(folder).rangefinders == ()
    with World(WorldConfig(airframe=str(folder), rangefinders=True)) as world:
        world.step()
        assert world.poll_rangefinders() is None
