"""RGB cameras: projection against geometry, what the cameras see, rate, configuration errors."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import SKY_RGB, CameraSpec, camera_pose_enu, render, with_mount
from sitl.vehicles.multirotor import AIRFRAME_DIR, load_airframe
from sitl.world import World, WorldConfig

FRD_TO_FLU = np.diag([1.0, -1.0, -1.0])


def _expected_optical(spec: CameraSpec, point_frd: np.ndarray) -> np.ndarray:
    """Optical-frame coordinates of a body-FRD vector from the camera, for the presets tested.

    Written out per mount (not with the code's rotation): down = (right, back, down),
    forward = (right, down, forward), right-looking (yaw 90) = (back, down, right).
    """
    x, y, z = point_frd
    if spec.pitch_deg == -90.0 and spec.yaw_deg == 0.0:
        return np.array([y, -x, z])
    if spec.pitch_deg == 0.0 and spec.yaw_deg == 0.0:
        return np.array([y, z, x])
    if spec.pitch_deg == 0.0 and spec.yaw_deg == 90.0:
        return np.array([-x, z, y])
    raise AssertionError("no hand-written expectation for this mount")


@pytest.mark.parametrize(
    ("mount", "euler_zyx_deg", "marker_offset_frd_m"),
    [
        # down camera, vehicle yawed and tilted; marker below, ahead and to the right
        ({"pitch_deg": -90.0}, (30.0, 8.0, -5.0), (1.5, 2.0, 6.0)),
        # forward camera, level; marker ahead, left and low
        ({"pitch_deg": 0.0}, (0.0, 0.0, 0.0), (6.0, -1.5, 1.0)),
        # forward camera, vehicle yawed 120 deg and rolled; marker ahead, right, high
        ({"pitch_deg": 0.0}, (120.0, 0.0, 10.0), (5.0, 1.0, -1.2)),
        # right-looking camera: marker to the right, a little ahead
        ({"pitch_deg": 0.0, "yaw_deg": 90.0}, (-45.0, 3.0, 0.0), (0.8, 5.0, 0.5)),
    ],
)
def test_a_marker_lands_on_the_pixel_the_intrinsics_predict(
    mount, euler_zyx_deg, marker_offset_frd_m
):
    """A 0.2 m box at a known world point: its pixels' centroid is K's projection within 1 px.

    The point's optical coordinates are computed independently from the body pose (FLU->ENU
    rotation) and the hand-written axes of each mount, so this checks the FRD mount, the view
    matrix, the projection matrix and the image orientation together.
    """
    spec = CameraSpec(width_px=320, height_px=240, hfov_deg=90.0, **mount)
    body_position = np.array([3.0, -2.0, 12.0])
    rotation = Rotation.from_euler("ZYX", np.radians(euler_zyx_deg)).as_matrix()
    camera_enu = body_position + rotation @ FRD_TO_FLU @ np.array(spec.position_frd_m)
    marker_enu = camera_enu + rotation @ FRD_TO_FLU @ np.array(marker_offset_frd_m)
    marker = BoxObstacle(tuple(marker_enu), (0.2, 0.2, 0.2), rgba=(1.0, 0.0, 1.0, 1.0))
    with World(WorldConfig(obstacles=(marker,))) as world:
        centre, axes = camera_pose_enu(spec, body_position, rotation)
        np.testing.assert_allclose(centre, camera_enu, atol=1e-12)
        _, seg = render(world._scene.client_id, spec, centre, axes, segmentation=True)
        rows, cols = np.nonzero(seg == world.obstacle_ids[0])
    assert rows.size > 20, "the marker is not in the image"
    centroid = np.array([cols.mean() + 0.5, rows.mean() + 0.5])  # pixel k spans [k, k + 1)
    expected = spec.intrinsics().project(_expected_optical(spec, np.array(marker_offset_frd_m)))
    np.testing.assert_allclose(centroid, expected[0], atol=1.0)


def test_the_down_camera_sees_the_textured_ground():
    """From 10 m the down camera sees only ground (no sky), varied, changing as it moves."""
    config = WorldConfig(cameras=True, spawn_altitude_m=10.0)
    with World(config) as world:
        frames = None
        while frames is None:
            world.step()
            frames = world.poll_cameras()
        [frame] = frames
        rgb = frame.rgb
        assert rgb.shape == (240, 320, 3) and rgb.dtype == np.uint8
        assert not np.any(np.all(rgb == SKY_RGB, axis=2)), "sky seen looking down from 10 m"
        assert rgb.std() > 10.0
        assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 1000
        # The ground is green-brown: green is the dominant channel on average.
        assert rgb[..., 1].mean() > rgb[..., 2].mean()
        # Two metres east the picture is another one (the texture is not uniform).
        spec = world.camera_specs[0]
        moved, axes = camera_pose_enu(
            spec, world.truth.position_enu_m[0] + [2.0, 0.0, 0.0], world._scene.rotation[0]
        )
        other, _ = render(world._scene.client_id, spec, moved, axes)
        assert np.abs(other.astype(int) - rgb.astype(int)).mean() > 10.0


def test_the_forward_camera_sees_a_wall_where_it_should():
    """A blue wall 4 m wide, 3 m ahead, fills exactly the image region its corners project to.

    Columns |x / z| < 2 / distance, rows above the wall's foot (the ground is seen below it).
    """
    spec = with_mount(CameraSpec(width_px=320, height_px=240, hfov_deg=90.0), "forward")
    wall = BoxObstacle((0.0, 3.0 + 0.1, 5.0), (4.0, 0.2, 10.0), rgba=(0.1, 0.2, 0.9, 1.0))
    config = WorldConfig(cameras=True, camera=spec, spawn_altitude_m=2.0, obstacles=(wall,))
    with World(config) as world:
        world.step()
        while (frames := world.poll_cameras()) is None:
            world.step()
        rgb = frames[0].rgb.astype(int)
        east, north, up = frames[0].position_enu_m  # vehicle faces north, the wall's face: y = 3
    distance = 3.0 - north
    k = spec.intrinsics()
    left = k.cx_px + k.fx_px * (-2.0 - east) / distance
    right = k.cx_px + k.fx_px * (2.0 - east) / distance
    foot = k.cy_px + k.fy_px * up / distance
    assert 0 < left < right < k.width_px and k.cy_px < foot < k.height_px - 10
    blue = (rgb[..., 2] > 2 * rgb[..., 0] + 20) & (rgb[..., 2] > 2 * rgb[..., 1] + 20)
    inside = blue[: int(foot) - 1, int(np.ceil(left)) + 1 : int(np.floor(right)) - 1]
    assert inside.all()
    assert not blue[int(foot) + 2 :].any()
    assert not blue[:, : int(np.floor(left)) - 1].any()
    assert not blue[:, int(np.ceil(right)) + 1 :].any()


def test_frames_are_due_only_at_the_camera_rate():
    """At 10 Hz of 500 Hz physics: one frame every 50 steps, at those steps, once each."""
    with World(WorldConfig(cameras=True, spawn_altitude_m=5.0)) as world:
        times = []
        for _ in range(500):
            world.step()
            frames = world.poll_cameras()
            if frames is not None:
                assert world.poll_cameras() is None  # a second poll at the same time
                times.append(frames[0].time_s)
                assert frames[0].vehicle == 0
        np.testing.assert_allclose(times, np.arange(1, 11) * 0.1)


def test_every_vehicle_with_a_camera_gets_its_frame_and_others_none():
    """A mixed fleet: the Typhoons' frames in vehicle order, the x500 (no camera) has none."""
    config = WorldConfig(
        n_vehicles=3, airframe=("typhoon_h480", "x500", "typhoon_h480"), cameras=True
    )
    with World(config) as world:
        assert world.camera_specs[1] is None
        assert world.camera_specs[0] == load_airframe("typhoon_h480").camera
        for _ in range(50):
            world.step()
        frames = world.poll_cameras()
        assert [f.vehicle for f in frames] == [0, 2]
        np.testing.assert_allclose(
            frames[1].position_enu_m[0] - frames[0].position_enu_m[0], 2 * config.spacing_m
        )


def test_one_camera_per_vehicle():
    """A tuple gives each vehicle its own camera (None: none); a wrong length names the field."""
    down, forward = CameraSpec(), with_mount(CameraSpec(rate_hz=5.0), "forward")
    config = WorldConfig(n_vehicles=3, cameras=True, camera=(down, None, forward))
    with World(config) as world:
        assert world.camera_specs == (down, None, forward)
        for _ in range(100):
            world.step()
        assert [f.vehicle for f in world.poll_cameras()] == [0, 2]
    with pytest.raises(ValueError, match="camera: 2 entries for 3 vehicles"):
        WorldConfig(n_vehicles=3, cameras=True, camera=(down, forward))
    with pytest.raises(ValueError, match=r"camera\[1\].rate_hz"):
        WorldConfig(n_vehicles=2, cameras=True, camera=(down, CameraSpec(rate_hz=3.0)))


def test_cameras_are_off_by_default_and_change_no_other_sensor():
    """No camera without ``cameras``; with them, the other sensors' draws are the same."""
    with World(WorldConfig()) as world:
        assert world.camera_specs == (None,)
        world.step()
        assert world.poll_cameras() is None
    readings = []
    for cameras in (False, True):
        with World(WorldConfig(cameras=cameras, seed=3)) as world:
            values = []
            for _ in range(100):
                world.step()
                sensors, _ = world.poll_sensors()
                world.poll_cameras()
                if sensors is not None:
                    values.append((sensors[0].xacc, sensors[0].zgyro, sensors[0].abs_pressure))
            readings.append(values)
    assert readings[0] == readings[1]


def test_the_vehicle_does_not_see_itself():
    """The Typhoon's camera, down and forward, sees no part of its own body (segmentation)."""
    typhoon = load_airframe("typhoon_h480").camera
    for mount in ("down", "forward"):
        config = WorldConfig(cameras=True, camera=with_mount(typhoon, mount), spawn_altitude_m=3)
        with World(config) as world:
            scene = world._scene
            seen = world._cameras.visible_bodies(0, scene.position_enu_m[0], scene.rotation[0])
            assert scene.body_ids[0] not in seen
            assert scene.ground_id in seen


@pytest.mark.parametrize(
    ("config", "field"),
    [
        ({"camera": CameraSpec(rate_hz=1000.0)}, "camera.rate_hz"),
        ({"camera": CameraSpec(rate_hz=7.0)}, "camera.rate_hz"),
        ({"camera": CameraSpec(position_frd_m=(0.5, 0.0, 0.2))}, "position_frd_m"),
        # behind and below the fuselage, looking forward: the skids and fuselage are in view
        (
            {"camera": CameraSpec(position_frd_m=(-0.2, 0.0, 0.1), pitch_deg=0.0, hfov_deg=110)},
            "own body",
        ),
        ({"camera": CameraSpec()}, None),  # a good one, for contrast
    ],
)
def test_bad_camera_configurations_fail_at_load_naming_the_field(config, field):
    if field is None:
        World(WorldConfig(cameras=True, **config)).close()
        return
    with pytest.raises(ValueError, match=field):
        World(WorldConfig(cameras=True, **config)).close()


@pytest.mark.parametrize("field", ["width_px", "height_px"])
def test_a_zero_resolution_names_the_field(field):
    with pytest.raises(ValueError, match=field):
        CameraSpec(**{field: 0})


def test_a_spec_without_cameras_on_is_an_error():
    with pytest.raises(ValueError, match="cameras=False"):
        WorldConfig(camera=CameraSpec())


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"rate_hz": 0.0}, "rate_hz"),
        ({"width_px": 0}, "width_px"),
        ({"position_frd_m": [0.0, 0.0, 0.9]}, "position_frd_m"),
        ({"zoom": 2}, "unknown keys"),
    ],
)
def test_a_bad_camera_section_of_an_airframe_names_file_and_field(tmp_path, change, field):
    folder = tmp_path / "typhoon_h480"
    shutil.copytree(AIRFRAME_DIR / "typhoon_h480", folder)
    path = folder / "typhoon_h480.yaml"
    data = yaml.safe_load(path.read_text())
    data["camera"].update(change)
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ValueError, match=field) as error:
        load_airframe(folder)
    assert "typhoon_h480.yaml" in str(error.value)


def test_the_airframe_rate_must_divide_the_physics_rate():
    """The Typhoon's 10 Hz camera cannot run with 125 Hz physics (12.5 steps per frame)."""
    with pytest.raises(ValueError, match="rate_hz"):
        World(
            WorldConfig(
                cameras=True,
                physics_hz=125.0,
                imu_hz=125.0,
                baro_hz=25.0,
                mag_hz=25.0,
                gps_hz=5.0,
                battery_hz=25.0,
            )
        ).close()
