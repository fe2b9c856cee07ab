"""People in a forward camera: colour blobs in frames, and who a camera could see (ground truth).

The indoor world's people wear high-visibility orange (``worlds.Person.rgba`` about
(0.95, 0.45, 0.1)); nothing else in the plant has that hue (machinery is blue, pipes yellow,
walls and floor grey). :func:`find_people` finds the orange blobs of an RGB frame by hue and
saturation (shading changes brightness, not hue) and places each on the floor through the pixel
under its lowest row (the feet), with the camera's geometry; :class:`SpillCounter` then merges
repeated sightings of one person. :func:`people_in_view` is the ground truth a run's result
compares against: which people were within range, inside the horizontal and vertical field of
view, with no obstacle footprint across the line of sight.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from companion.perception.camera_model import CameraModel
from companion.perception.spill_detector import Blob, Detection


@dataclass(frozen=True)
class PersonColour:
    """HSV window of the people's colour (OpenCV scale: hue 0..180, saturation/value 0..255)."""

    hue_min: int = 6
    hue_max: int = 18
    """Orange (0.95, 0.45, 0.1) has hue 12; the pipes' yellow 22, the machinery's blue 110."""
    saturation_min: int = 140
    value_min: int = 60
    min_area_px: int = 6
    """Smallest blob counted, pixels."""

    def __post_init__(self) -> None:
        if not 0 <= self.hue_min <= self.hue_max <= 180:
            raise ValueError(f"hue_min/hue_max must satisfy 0 <= min <= max <= 180, got {self}")
        for name in ("saturation_min", "value_min"):
            if not 0 <= getattr(self, name) <= 255:
                raise ValueError(f"{name} must be in [0, 255], got {getattr(self, name)!r}")
        if self.min_area_px < 1:
            raise ValueError(f"min_area_px must be >= 1, got {self.min_area_px!r}")


def person_mask(rgb: np.ndarray, colour: PersonColour = PersonColour()) -> np.ndarray:
    """Boolean (H, W) mask of the pixels of the people's colour in an RGB uint8 frame."""
    image = np.asarray(rgb)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"rgb must be an (H, W, 3) image, got shape {image.shape}")
    hsv = cv2.cvtColor(image.astype(np.uint8), cv2.COLOR_RGB2HSV)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    return (
        (h >= colour.hue_min)
        & (h <= colour.hue_max)
        & (s >= colour.saturation_min)
        & (v >= colour.value_min)
    )


def find_people(
    rgb: np.ndarray,
    camera: CameraModel,
    body_position_enu_m: Sequence[float],
    rotation_flu_enu: np.ndarray,
    colour: PersonColour = PersonColour(),
) -> list[Detection]:
    """The orange blobs of a frame placed on the floor (z = 0) under their lowest pixels.

    Blobs whose feet ray does not meet the floor (at or above the horizon) are dropped.
    """
    mask = person_mask(rgb, colour).astype(np.uint8)
    count, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    h, w = mask.shape
    out = []
    for i in range(1, count):
        x, y, bw, bh, area = (int(v) for v in stats[i])
        if area < colour.min_area_px:
            continue
        u = float(centroids[i][0]) + 0.5
        feet = camera.pixels_to_ground(
            np.array([[u, float(y + bh)]]), body_position_enu_m, rotation_flu_enu
        )[0]
        if not np.isfinite(feet).all():
            continue
        border = x == 0 or y == 0 or x + bw == w or y + bh == h
        blob = Blob((u, float(centroids[i][1]) + 0.5), area, border)
        out.append(Detection(tuple(float(c) for c in feet), 0.3, blob))
    return out


def people_in_view(
    people_enu_m: np.ndarray,
    heights_m: np.ndarray,
    camera_enu_m: Sequence[float],
    heading_enu_rad: float,
    hfov_deg: float,
    vfov_deg: float,
    range_m: float,
    obstacles: Sequence[Polygon],
) -> np.ndarray:
    """Mask (P,) of the people a level forward camera sees.

    A person is seen when the middle of their body is within ``range_m`` of the camera, inside
    half of each field of view around the optical axis (horizontal, pointing ``heading_enu_rad``
    counter-clockwise from east; level), and the straight ground line between them crosses no
    obstacle footprint.
    """
    people = np.asarray(people_enu_m, dtype=float).reshape(-1, 3)
    if len(people) == 0:
        return np.zeros(0, dtype=bool)
    cam = np.asarray(camera_enu_m, dtype=float)
    middle = people.copy()
    middle[:, 2] += np.asarray(heights_m, dtype=float) / 2.0
    delta = middle - cam
    horizontal = np.hypot(delta[:, 0], delta[:, 1])
    distance = np.linalg.norm(delta, axis=1)
    bearing = np.arctan2(delta[:, 1], delta[:, 0]) - heading_enu_rad
    bearing = (bearing + math.pi) % (2.0 * math.pi) - math.pi
    elevation = np.arctan2(delta[:, 2], horizontal)
    seen = (
        (distance <= range_m)
        & (np.abs(bearing) <= math.radians(hfov_deg) / 2.0)
        & (np.abs(elevation) <= math.radians(vfov_deg) / 2.0)
    )
    if seen.any() and obstacles:
        lines = [LineString([tuple(cam[:2]), tuple(p[:2])]) for p in people[seen]]
        blocked = shapely.union_all(list(obstacles))
        shapely.prepare(blocked)
        clear = ~shapely.intersects(blocked, lines)
        seen[np.flatnonzero(seen)] = clear
    return seen


def vertical_fov_deg(hfov_deg: float, width_px: int, height_px: int) -> float:
    """Vertical field of view of a pinhole camera with square pixels, degrees."""
    half = math.atan(math.tan(math.radians(hfov_deg) / 2.0) * height_px / width_px)
    return math.degrees(2.0 * half)
