"""People in frames (orange blobs placed on the floor) and in view (ground truth)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import box

from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_euler
from companion.perception.person_detector import (
    PersonColour,
    find_people,
    people_in_view,
    person_mask,
    vertical_fov_deg,
)

FORWARD = CameraModel(width_px=320, height_px=240, hfov_deg=90.0, pitch_deg=0.0,
                      position_frd_m=(0.0, 0.0, 0.0))  # fmt: skip


def _frame() -> np.ndarray:
    """Grey floor, a blue machine, a yellow pipe."""
    rgb = np.full((240, 320, 3), (120, 118, 110), np.uint8)
    rgb[100:140, 20:60] = (50, 90, 150)
    rgb[30:36, :] = (178, 140, 25)
    return rgb


def test_mask_picks_the_orange_not_pipes_machines_or_floor() -> None:
    rgb = _frame()
    assert not person_mask(rgb).any()
    rgb[150:200, 200:210] = (242, 115, 25)  # lit orange
    rgb[150:200, 210:215] = (121, 57, 12)  # the same in shadow
    mask = person_mask(rgb)
    assert mask[150:200, 200:215].all() and mask.sum() == 50 * 15


def test_find_people_places_the_feet_on_the_floor() -> None:
    # level camera 1.5 m up at the origin looking north; a person 4 m ahead, 1 m to the right
    pose = np.array([0.0, 0.0, 1.5])
    rotation = rotation_flu_enu_from_euler(0.0, 0.0, 0.0)
    feet = np.array([[1.0, 4.0, 0.0]])
    u, v = FORWARD.ground_to_pixels(feet, pose, rotation)[0]
    rgb = _frame()
    rgb[int(v) - 40 : int(v), int(u) - 3 : int(u) + 4] = (242, 115, 25)
    found = find_people(rgb, FORWARD, pose, rotation)
    assert len(found) == 1
    np.testing.assert_allclose(found[0].position_enu_m[:2], feet[0, :2], atol=0.25)
    # a blob above the horizon meets no floor: dropped
    sky = _frame()
    sky[10:20, 100:110] = (242, 115, 25)
    assert find_people(sky, FORWARD, pose, rotation) == []


def test_people_in_view_range_field_and_line_of_sight() -> None:
    people = np.array(
        [
            [0.0, 5.0, 0.0],  # ahead
            [0.0, -5.0, 0.0],  # behind
            [0.0, 20.0, 0.0],  # too far
            [6.0, 6.0, 0.0],  # 45 deg right: inside a 114 deg field, outside a 60 deg one
            [-2.0, 5.0, 0.0],  # ahead-left, behind a wall
        ]
    )
    heights = np.full(5, 1.7)
    wall = box(-3.5, 2.0, -0.5, 2.3)
    heading_north = math.pi / 2.0
    seen = people_in_view(
        people, heights, (0.0, 0.0, 1.5), heading_north, 114.6, 98.0, 10.0, [wall]
    )
    assert seen.tolist() == [True, False, False, True, False]
    narrow = people_in_view(people, heights, (0.0, 0.0, 1.5), heading_north, 60.0, 45.0, 10.0, [])
    assert narrow.tolist() == [True, False, False, False, True]
    assert people_in_view(np.zeros((0, 3)), np.zeros(0), (0, 0, 1), 0.0, 90, 70, 5, []).size == 0


def test_vertical_field_of_view() -> None:
    assert vertical_fov_deg(90.0, 320, 320) == pytest.approx(90.0)
    assert vertical_fov_deg(90.0, 320, 240) == pytest.approx(2 * math.degrees(math.atan(0.75)))


def test_bad_colour_window_names_the_field() -> None:
    with pytest.raises(ValueError, match="hue"):
        PersonColour(hue_min=20, hue_max=10)
    with pytest.raises(ValueError, match="min_area_px"):
        PersonColour(min_area_px=0)
