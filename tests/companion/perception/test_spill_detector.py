"""Spill detection: dark blobs found, located on the sea through the camera model, counted once."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from companion.perception.camera_model import (
    CameraModel,
    rotation_flu_enu_from_euler,
    rotation_flu_enu_from_quaternion,
)
from companion.perception.spill_detector import (
    Blob,
    Detection,
    DetectorConfig,
    SpillCounter,
    detect_spills,
    find_blobs,
)

SEA_RGB = (11, 52, 83)
OIL_RGB = (14, 12, 12)
CAMERA = CameraModel(width_px=320, height_px=240, hfov_deg=90.0)


def _sea(rng: np.random.Generator, h: int = 240, w: int = 320) -> np.ndarray:
    """A sea frame: the sea colour with 18 % brightness noise per pixel, as the texture has."""
    noise = 1.0 + 0.18 * rng.standard_normal((h, w, 1))
    return np.clip(np.array(SEA_RGB) * noise, 0, 255).astype(np.uint8)


def test_blobs_are_found_where_they_are_drawn_and_the_sea_gives_none():
    """Two dark discs and one too small: two blobs, centroids within 0.5 px, noise ignored."""
    rng = np.random.default_rng(1)
    frame = _sea(rng)
    assert find_blobs(frame) == []
    yy, xx = np.mgrid[0:240, 0:320] + 0.5  # pixel centres
    for (u, v), r in (((100.0, 80.0), 15.0), ((250.0, 170.0), 8.0), ((40.0, 200.0), 1.5)):
        frame[(xx - u) ** 2 + (yy - v) ** 2 <= r * r] = OIL_RGB
    blobs = find_blobs(frame)
    assert [b.area_px for b in blobs] == sorted((b.area_px for b in blobs), reverse=True)
    assert len(blobs) == 2
    np.testing.assert_allclose(blobs[0].centroid_uv, (100.0, 80.0), atol=0.5)
    np.testing.assert_allclose(blobs[1].centroid_uv, (250.0, 170.0), atol=0.5)
    assert blobs[0].area_px == pytest.approx(math.pi * 15.0**2, rel=0.1)
    assert not blobs[0].touches_border
    # A blob cut by the image's edge says so.
    frame[100:120, 0:10] = OIL_RGB
    assert any(b.touches_border for b in find_blobs(frame))


def test_the_projection_inverts_the_camera_model():
    """Ground points -> pixels -> ground points round trip, for tilted and yawed vehicles."""
    rng = np.random.default_rng(2)
    for mount in (CAMERA, CameraModel(pitch_deg=-60.0, yaw_deg=20.0, hfov_deg=80.0)):
        for _ in range(5):
            rotation = rotation_flu_enu_from_euler(*rng.uniform([-10, -10, 0], [10, 10, 360]))
            body = np.array([*rng.uniform(-50, 50, 2), rng.uniform(10, 80)])
            # Points that the camera sees: rays through random pixels, projected out.
            pixels = rng.uniform([0, 0], [mount.width_px, mount.height_px], (20, 2))
            ground = mount.pixels_to_ground(pixels, body, rotation)
            ok = np.isfinite(ground).all(axis=1)
            assert ok.sum() >= 10
            np.testing.assert_allclose(ground[ok, 2], 0.0, atol=1e-9)
            back = mount.ground_to_pixels(ground[ok], body, rotation)
            np.testing.assert_allclose(back, pixels[ok], atol=1e-6)


def test_a_down_camera_on_a_level_vehicle_sees_north_up_the_image():
    """Level, heading north, camera down at 20 m: the image centre is below the camera, the top
    of the image is north (ahead), the right is east; the footprint is 2 h tan(hfov/2) wide."""
    body = np.array([5.0, 7.0, 20.0])
    level_north = rotation_flu_enu_from_euler(0.0, 0.0, 0.0)
    cam = CameraModel(hfov_deg=90.0, position_frd_m=(0.0, 0.0, 0.0))
    centre = cam.pixels_to_ground(
        np.array([[160.0, 120.0], [160.0, 0.0], [320.0, 120.0]]), body, level_north
    )
    np.testing.assert_allclose(centre[0], (5.0, 7.0, 0.0), atol=1e-9)
    assert centre[1][1] > 7.0 and centre[2][0] > 5.0
    footprint = cam.footprint(body, level_north)
    x0, _, x1, _ = footprint.bounds
    assert x1 - x0 == pytest.approx(2 * 20.0 * math.tan(math.radians(45.0)))


def test_the_mavsdk_quaternion_and_the_euler_angles_agree():
    """NED->FRD quaternion (w, x, y, z) and PX4 Euler angles give the same FLU->ENU rotation."""
    euler = (5.0, -8.0, 135.0)
    q = Rotation.from_euler("ZYX", [euler[2], euler[1], euler[0]], degrees=True).as_quat()
    from_q = rotation_flu_enu_from_quaternion(q[3], q[0], q[1], q[2])
    np.testing.assert_allclose(from_q, rotation_flu_enu_from_euler(*euler), atol=1e-12)
    # Heading 90 (east): the body's forward (FLU x) points east.
    np.testing.assert_allclose(
        rotation_flu_enu_from_euler(0, 0, 90) @ [1, 0, 0], [1, 0, 0], atol=1e-12
    )
    with pytest.raises(ValueError, match="quaternion"):
        rotation_flu_enu_from_quaternion(0, 0, 0, 0)


def test_detections_land_where_the_spill_is_on_the_sea():
    """A spill drawn at the pixels of a known sea point is located there (tilted, yawed vehicle)."""
    rng = np.random.default_rng(3)
    rotation = rotation_flu_enu_from_euler(3.0, -4.0, 30.0)
    body = np.array([100.0, -50.0, 40.0])
    spill_xy = np.array([108.0, -45.0])
    # Draw the disc of radius 5 m on the sea: every pixel whose ground point is within 5 m.
    frame = _sea(rng)
    vv, uu = np.mgrid[0:240, 0:320] + 0.5
    ground = CAMERA.pixels_to_ground(np.column_stack((uu.ravel(), vv.ravel())), body, rotation)
    inside = (np.hypot(*(ground[:, :2] - spill_xy).T) <= 5.0).reshape(240, 320)
    frame[inside] = OIL_RGB
    [d] = detect_spills(frame, CAMERA, body, rotation)
    assert np.hypot(*(np.array(d.position_enu_m[:2]) - spill_xy)) < 0.5
    assert d.radius_m == pytest.approx(5.0, rel=0.1)
    with pytest.raises(ValueError, match="frame is 100x100"):
        detect_spills(frame[:100, :100], CAMERA, body, rotation)


def _detection(x: float, y: float, radius: float = 3.0) -> Detection:
    return Detection((x, y, 0.0), radius, Blob((0.0, 0.0), 50, False))


def test_the_counter_merges_repeated_sightings_and_keeps_distinct_spills():
    """Sightings of one spill a few metres apart are one; two far apart are two."""
    counter = SpillCounter(merge_radius_m=10.0)
    assert counter.add([_detection(0.0, 0.0), _detection(50.0, 0.0)]) == 2
    assert counter.add([_detection(4.0, 3.0)]) == 0  # the first one again
    assert counter.add([_detection(52.0, -1.0), _detection(0.0, 30.0)]) == 1
    assert counter.count == 3
    # A big spill seen off-centre: within the sum of the radii, though beyond merge_radius_m.
    assert counter.add([_detection(0.0, 48.0, radius=15.0)]) == 0
    assert counter.count == 3
    with pytest.raises(ValueError, match="merge_radius_m"):
        SpillCounter(merge_radius_m=-1.0)
    with pytest.raises(ValueError, match="dark_max"):
        DetectorConfig(dark_max=300)
