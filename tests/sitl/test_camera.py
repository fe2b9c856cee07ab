"""RGB cameras: projection against geometry, what the cameras see, rate, configuration errors."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import cv2
import numpy as np
import pybullet as p
import pytest
import yaml
from scipy.spatial.transform import Rotation

from sitl.physics.obstacles import BoxObstacle
from sitl.sensors.camera import (
    SKY_RGB,
    CameraSpec,
    camera_pose_enu,
    optical_axes_frd,
    with_mount,
)
from sitl.sensors.camera_render import CameraRig, TinyLight, render
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
    """A 0.2 m box at a known world point: its pixels' centroid is K's projection within 0.4 px.

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
    np.testing.assert_allclose(centroid, expected[0], atol=0.4)


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
        other = world._cameras.render_camera(0, moved, axes)
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


# -- the ground drawn per pixel ray, composited with TinyRenderer's bodies ----------------------


def _add_textured_ground_quad(client_id: int, texture_rgb: np.ndarray, tile_m: float) -> int:
    """The ground as TinyRenderer drew it before: a 2 km textured square at z = 0 (body id).

    uvs (x, y) / tile_m: the texture repeats every tile. Visual only (no collision shape).
    """
    h = 1000.0
    r = h / tile_m
    visual = p.createVisualShape(
        p.GEOM_MESH,
        vertices=[[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]],
        indices=[0, 1, 2, 0, 2, 3],
        uvs=[[-r, -r], [r, -r], [r, r], [-r, r]],
        normals=[[0.0, 0.0, 1.0]] * 4,
        rgbaColor=[1.0, 1.0, 1.0, 1.0],
        physicsClientId=client_id,
    )
    body = p.createMultiBody(0.0, -1, visual, physicsClientId=client_id)
    with tempfile.TemporaryDirectory() as folder:
        path = str(Path(folder) / "ground.png")
        assert cv2.imwrite(path, np.ascontiguousarray(texture_rgb[:, :, ::-1]))
        texture = p.loadTexture(path, physicsClientId=client_id)
    p.changeVisualShape(body, -1, textureUniqueId=texture, physicsClientId=client_id)
    return body


def _pose(spec: CameraSpec, position_enu_m, euler_zyx_deg=(0.0, 0.0, 0.0)):
    """Optical centre and rotation optical -> ENU of a camera on a body at that pose."""
    rotation = Rotation.from_euler("ZYX", np.radians(euler_zyx_deg)).as_matrix()
    return camera_pose_enu(spec, np.asarray(position_enu_m, dtype=float), rotation)


@pytest.mark.parametrize(
    ("mount", "position", "euler_zyx_deg"),
    [
        ({"pitch_deg": -90.0}, (3.3, -1.7, 10.0), (20.0, 0.0, 0.0)),  # down
        ({"pitch_deg": -90.0}, (734.5, -687.6, 25.0), (-75.0, 6.0, -4.0)),  # far from 0
        ({"pitch_deg": -30.0}, (-13.1, 7.7, 6.0), (-70.0, 3.0, 2.0)),  # oblique
        ({"pitch_deg": 0.0}, (2.0, 5.0, 1.5), (130.0, 0.0, 0.0)),  # forward, horizon
    ],
)
def test_the_ground_looks_as_tinyrenderer_drew_the_textured_quad(mount, position, euler_zyx_deg):
    """The composited frame matches TinyRenderer's render of the old textured ground quad.

    Same texture, same pose: at least 97 % of the ground pixels within 3 levels per channel
    (nearest-texel boundaries and TinyRenderer's rounding differ on a few), small mean
    difference, and the same pixels see sky.
    """
    spec = CameraSpec(width_px=320, height_px=240, hfov_deg=90.0, far_m=300.0, **mount)
    with World(WorldConfig(cameras=True, camera=spec, spawn_altitude_m=200.0)) as world:
        rig, cid = world._cameras, world._scene.client_id
        centre, axes = _pose(spec, position, euler_zyx_deg)
        ours = rig.render_camera(0, centre, axes).astype(int)
        quad = _add_textured_ground_quad(cid, rig.ground_texture_rgb, rig.tile_m)
        old, seg = render(cid, spec, centre, axes, segmentation=True)
    old = old.astype(int)
    old_ground = seg == quad
    our_sky = np.all(ours == SKY_RGB, axis=2)
    # TinyRenderer draws the quad to its 1 km edge, beyond far_m; ours stops at far_m.
    assert (old_ground | our_sky).all(), "ground where TinyRenderer saw none"
    ground = old_ground & ~our_sky
    assert ground.mean() > 0.4
    difference = np.abs(ours - old)[ground]
    assert (difference.max(axis=1) <= 3).mean() >= 0.97
    assert difference.mean() < 1.5
    assert ((old_ground & our_sky).mean()) < 0.01


def test_a_box_on_the_ground_hides_the_ground_behind_it_and_nothing_else():
    """A magenta box standing on the ground, seen obliquely: its pixels magenta, the rest ground.

    Where TinyRenderer's segmentation shows the box, the frame is magenta-ish (lit magenta: red
    and blue well above green); nowhere else.
    """
    box = BoxObstacle((8.0, 0.0, 1.0), (2.0, 2.0, 2.0), rgba=(1.0, 0.0, 1.0, 1.0))
    spec = CameraSpec(width_px=320, height_px=240, hfov_deg=90.0, pitch_deg=-30.0)
    config = WorldConfig(cameras=True, camera=spec, spawn_altitude_m=30.0, obstacles=(box,))
    with World(config) as world:
        centre, axes = _pose(spec, (0.0, 0.0, 5.0))
        rgb = world._cameras.render_camera(0, centre, axes).astype(int)
        _, seg = render(world._scene.client_id, spec, centre, axes, segmentation=True)
        box_pixels = seg == world.obstacle_ids[0]
    magenta = (rgb[..., 0] > rgb[..., 1] + 80) & (rgb[..., 2] > rgb[..., 1] + 80)
    assert box_pixels.sum() > 1000
    np.testing.assert_array_equal(magenta, box_pixels)
    assert not np.any(np.all(rgb == SKY_RGB, axis=2)[~box_pixels & (np.arange(240) > 40)[:, None]])


def test_the_ground_hides_the_buried_part_of_a_box():
    """A box half sunk into the ground, seen level from 1.5 m: its magenta ends at its foot.

    TinyRenderer alone draws the buried half (down to z = -1 m); the composited frame's lowest
    magenta row is the projection of the line where the box's face meets the ground.
    """
    distance, up = 6.0, 1.5
    box = BoxObstacle((distance + 1.0, 0.0, 0.0), (2.0, 2.0, 2.0), rgba=(1.0, 0.0, 1.0, 1.0))
    spec = CameraSpec(width_px=320, height_px=240, hfov_deg=90.0, pitch_deg=0.0)
    config = WorldConfig(cameras=True, camera=spec, spawn_altitude_m=30.0, obstacles=(box,))
    with World(config) as world:
        _, axes = _pose(spec, (0.0, 0.0, up))  # the body faces east (FLU = ENU)
        centre = np.array([0.0, 0.0, up])
        rgb = world._cameras.render_camera(0, centre, axes).astype(int)
        alone, _ = render(world._scene.client_id, spec, centre, axes)
    k = spec.intrinsics()

    def lowest_magenta_row(image):
        image = image.astype(int)
        magenta = (image[..., 0] > image[..., 1] + 80) & (image[..., 2] > image[..., 1] + 80)
        return np.nonzero(magenta.any(axis=1))[0].max()

    foot = k.cy_px + k.fy_px * up / distance - 0.5  # pixel v's centre: v + 0.5
    buried_bottom = k.cy_px + k.fy_px * (up + 1.0) / distance - 0.5
    assert abs(lowest_magenta_row(rgb) - foot) <= 1.0
    assert abs(lowest_magenta_row(alone) - buried_bottom) <= 1.0


def test_the_horizon_of_a_level_forward_camera_is_the_principal_row():
    """Level, 1.5 m up, far clip 500 m: sky above the principal row, ground below (within 1 px)."""
    spec = CameraSpec(width_px=320, height_px=240, hfov_deg=90.0, pitch_deg=0.0, far_m=500.0)
    with World(WorldConfig(cameras=True, camera=spec)) as world:
        centre, axes = _pose(spec, (7.0, -3.0, 1.5), (35.0, 0.0, 0.0))
        rgb = world._cameras.render_camera(0, centre, axes)
    sky_rows = np.all(rgb == SKY_RGB, axis=(1, 2))
    first_ground_row = np.argmin(sky_rows)
    assert sky_rows[:first_ground_row].all() and not sky_rows[first_ground_row:].any()
    assert abs(first_ground_row - spec.intrinsics().cy_px) <= 1.0


def test_frames_without_a_body_in_view_skip_tinyrenderer_and_are_the_same():
    """Skipping TinyRenderer when no body's box meets the frustum changes no pixel.

    Vehicle 0 put at random poses among boxes, a body drawn from its collision shape and other
    vehicles (many just outside its camera's view, some in it, some closer than the near clip):
    every frame of its camera equals the one composited with TinyRenderer's image.
    """
    rng = np.random.default_rng(5)
    boxes = tuple(
        BoxObstacle(
            tuple(rng.uniform([-4.0, -4.0, 0.1], [4.0, 4.0, 3.0])),
            tuple(rng.uniform(0.05, 0.6, 3)),
            yaw_deg=float(rng.uniform(0.0, 90.0)),
            rgba=(0.9, 0.1, 0.1, 1.0),
        )
        for _ in range(4)
    )
    spec = CameraSpec(width_px=160, height_px=120, hfov_deg=70.0, pitch_deg=-20.0, near_m=0.3)
    config = WorldConfig(
        n_vehicles=3, cameras=True, camera=spec, spawn_altitude_m=1.5, obstacles=boxes
    )
    with World(config) as world:
        rig, scene = world._cameras, world._scene
        # A body with no visual shape: TinyRenderer draws its collision box.
        bare = p.createCollisionShape(
            p.GEOM_BOX, halfExtents=[0.3, 0.2, 0.4], physicsClientId=scene.client_id
        )
        p.createMultiBody(0.0, bare, -1, [1.0, -2.0, 1.0], physicsClientId=scene.client_id)
        skipped = frames = 0
        # Turning on the spot in 2-degree steps, the frustum's edges sweep over every body:
        # some frames see a sliver of one, which too small a bounding box would miss.
        for position in rng.uniform([-5.0, -5.0, 0.5], [5.0, 5.0, 4.0], (3, 3)):
            tilt = rng.uniform(-20.0, 20.0, 2)
            for yaw in np.arange(0.0, 360.0, 2.0):
                rotation = Rotation.from_euler("ZYX", [yaw, *tilt], degrees=True)
                p.resetBasePositionAndOrientation(
                    scene.body_ids[0], position, rotation.as_quat(), physicsClientId=scene.client_id
                )
                scene.read_state()
                centre, axes = camera_pose_enu(spec, scene.position_enu_m[0], scene.rotation[0])
                before = rig.tiny_renders
                fast = rig.render_camera(0, centre, axes, on_own_vehicle=True)
                skipped += rig.tiny_renders == before
                frames += 1
                full = rig.render_camera(0, centre, axes, force_tiny=True)
                np.testing.assert_array_equal(fast, full)
    assert 0.15 * frames <= skipped <= 0.85 * frames, f"{skipped} of {frames} frames skipped"


def test_a_tilted_camera_optical_axes_are_orthonormal():
    """optical_axes_frd is a rotation for any mount (the rays rely on it)."""
    for pitch, yaw in ((-90.0, 0.0), (-35.0, 20.0), (10.0, -130.0)):
        axes = optical_axes_frd(CameraSpec(pitch_deg=pitch, yaw_deg=yaw))
        np.testing.assert_allclose(axes.T @ axes, np.eye(3), atol=1e-12)
        assert np.linalg.det(axes) == pytest.approx(1.0)


def test_the_rig_needs_one_body_id_per_vehicle():
    with pytest.raises(ValueError, match="vehicle ids"):
        CameraRig(0, [CameraSpec()], 500.0, np.zeros((16, 16, 3), np.uint8), 20.0, 0, [1, 2])


def test_a_light_from_above_lights_a_roof_brighter_than_a_low_sun_and_not_the_ground():
    """``CameraRig.light`` changes TinyRenderer's shading of the bodies, not the ground layer.

    A white box seen from straight above: its roof (normal up) is brighter with the light
    overhead than with the light 10 degrees above the horizon (Lambert: diffuse ~ sin of the
    elevation); the ground pixels around it are the same in both frames.
    """
    box = BoxObstacle((0.0, 0.0, 2.0), (8.0, 8.0, 4.0), rgba=(1.0, 1.0, 1.0, 1.0))
    spec = CameraSpec(width_px=160, height_px=120, hfov_deg=60.0)
    config = WorldConfig(cameras=True, camera=spec, spawn_altitude_m=30.0, obstacles=(box,))
    with World(config) as world:
        rig = world._cameras
        centre, axes = _pose(spec, (0.0, 0.0, 30.0))
        rig.light = TinyLight((0.0, 0.0, 1.0), ambient=0.3, diffuse=0.6)
        overhead = rig.render_camera(0, centre, axes).astype(int)
        rig.light = TinyLight((1.0, 0.0, np.tan(np.radians(10.0))), ambient=0.3, diffuse=0.6)
        low_sun = rig.render_camera(0, centre, axes).astype(int)
    roof = np.zeros(overhead.shape[:2], bool)
    roof[50:70, 70:90] = True  # the middle of the 8 m box at 26 m: about 36 px wide
    edge = np.zeros_like(roof)
    edge[:10] = True
    assert overhead[roof].mean() > low_sun[roof].mean() + 50
    np.testing.assert_array_equal(overhead[edge], low_sun[edge])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"direction_enu": (0.0, 0.0, 0.0)}, "direction_enu"),
        ({"direction_enu": (1.0, float("nan"), 0.0)}, "direction_enu"),
        ({"direction_enu": (0.0, 0.0, 1.0), "ambient": -0.1}, "ambient"),
    ],
)
def test_a_bad_light_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        TinyLight(**kwargs)
