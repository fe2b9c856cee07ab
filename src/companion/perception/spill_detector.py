"""Oil spills in camera frames: dark patches on the sea -> points on the sea in the world frame.

An oil film on the sea is near-black (the offshore world's spills are RGBA (0.06, 0.05, 0.05),
about (10, 8, 8) as rendered) while the sea, even in the troughs of its waves, keeps a
brighter green-blue channel (about (12, 52, 83) on average; the simulator's sea texture never
takes its brightest channel below about 45). So a pixel is "oil" when its
brightest channel is at most ``dark_max``; a morphological opening removes isolated pixels;
connected components of at least ``min_area_px`` pixels are the spills seen. Each component's
centroid is projected onto the sea (plane z = 0) with the camera's pose
(:mod:`companion.perception.camera_model`), its ground radius estimated from its pixel area at
that range. :class:`SpillCounter` merges the detections of successive frames that fall on the
same spill. Pure numpy/OpenCV; frames are RGB uint8 arrays (OpenCV's ``VideoCapture`` gives BGR:
convert first).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from companion.perception.camera_model import CameraModel


@dataclass(frozen=True)
class DetectorConfig:
    """Thresholds of the dark-patch detector."""

    dark_max: int = 28
    """A pixel is oil if its brightest channel is <= this (0..255)."""
    min_area_px: int = 12
    """Smallest component counted, pixels (after the opening)."""
    open_px: int = 3
    """Side of the square opening kernel, pixels (1: no opening)."""

    def __post_init__(self) -> None:
        if not 0 <= self.dark_max <= 255:
            raise ValueError(f"dark_max must be in [0, 255], got {self.dark_max!r}")
        if self.min_area_px < 1:
            raise ValueError(f"min_area_px must be >= 1, got {self.min_area_px!r}")
        if self.open_px < 1:
            raise ValueError(f"open_px must be >= 1, got {self.open_px!r}")


@dataclass(frozen=True)
class Blob:
    """One dark patch in an image."""

    centroid_uv: tuple[float, float]
    """Centroid, pixel coordinates (u right, v down; pixel k spans [k, k + 1))."""
    area_px: int
    """Pixels it covers."""
    touches_border: bool
    """Whether it reaches the image's edge (then only part of it is seen)."""


@dataclass(frozen=True)
class Detection:
    """A dark patch located on the sea."""

    position_enu_m: tuple[float, float, float]
    """Where its centroid's ray meets the plane z = 0, ENU m."""
    radius_m: float
    """Radius of a disc of its area on the sea, m (its size, for merging)."""
    blob: Blob


def find_blobs(rgb: np.ndarray, config: DetectorConfig = DetectorConfig()) -> list[Blob]:
    """The dark patches of an RGB (H, W, 3) uint8 frame, largest first."""
    image = np.asarray(rgb)
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"rgb must be an (H, W, 3) image, got shape {image.shape}")
    mask = (image.max(axis=2) <= config.dark_max).astype(np.uint8)
    if config.open_px > 1:
        kernel = np.ones((config.open_px, config.open_px), np.uint8)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
    count, _, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
    h, w = mask.shape
    blobs = []
    for i in range(1, count):
        x, y, bw, bh, area = (int(v) for v in stats[i])
        if area < config.min_area_px:
            continue
        border = x == 0 or y == 0 or x + bw == w or y + bh == h
        # OpenCV's centroid is in pixel indices; +0.5 for the pixels' centres.
        u, v = (float(c) + 0.5 for c in centroids[i])
        blobs.append(Blob((u, v), area, border))
    return sorted(blobs, key=lambda b: (-b.area_px, b.centroid_uv))


def detect_spills(
    rgb: np.ndarray,
    camera: CameraModel,
    body_position_enu_m: Sequence[float],
    rotation_flu_enu: np.ndarray,
    config: DetectorConfig = DetectorConfig(),
) -> list[Detection]:
    """The dark patches of a frame located on the sea, from the vehicle's pose at the exposure.

    Args:
        rgb: the frame, (H, W, 3) uint8 RGB; its size must be the camera's.
        camera: the camera's optics and mount.
        body_position_enu_m: the vehicle's centre of mass, ENU m.
        rotation_flu_enu: its attitude, rotation FLU -> ENU.
        config: thresholds.
    """
    shape = np.shape(rgb)
    if shape[:2] != (camera.height_px, camera.width_px):
        raise ValueError(
            f"frame is {shape[1]}x{shape[0]} but the camera is {camera.width_px}x{camera.height_px}"
        )
    blobs = find_blobs(rgb, config)
    if not blobs:
        return []
    uv = np.array([b.centroid_uv for b in blobs])
    ground = camera.pixels_to_ground(uv, body_position_enu_m, rotation_flu_enu)
    centre, _ = camera.pose_enu(body_position_enu_m, rotation_flu_enu)
    out = []
    for blob, point in zip(blobs, ground, strict=True):
        if not np.isfinite(point).all():
            continue
        # A pixel at range r covers about (r / f)^2 m^2 across the ray; seen obliquely more.
        range_m = float(np.linalg.norm(point - centre))
        cos_incidence = max(abs(centre[2]) / range_m, 1e-3)
        area_m2 = blob.area_px * (range_m / camera.focal_px) ** 2 / cos_incidence
        out.append(Detection(tuple(float(c) for c in point), math.sqrt(area_m2 / math.pi), blob))
    return out


@dataclass
class Spill:
    """One distinct spill the counter knows: where and how big, from how many detections."""

    position_enu_m: np.ndarray
    """Area-weighted mean of its detections, ENU m."""
    radius_m: float
    """Largest radius of its detections, m."""
    detections: int = 1
    weight: float = 0.0


@dataclass
class SpillCounter:
    """Distinct spills among detections, merged by distance.

    A detection within ``merge_radius_m`` of a known spill, or overlapping it (closer than the sum
    of their radii), is that spill seen again.
    """

    merge_radius_m: float = 10.0
    """Centre distance under which two detections are one spill, m."""
    spills: list[Spill] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.merge_radius_m) and self.merge_radius_m >= 0.0):
            raise ValueError(f"merge_radius_m must be >= 0, got {self.merge_radius_m!r}")

    @property
    def count(self) -> int:
        """Distinct spills seen so far."""
        return len(self.spills)

    def add(self, detections: Sequence[Detection]) -> int:
        """Take one frame's detections; return how many new spills they revealed."""
        new = 0
        for d in detections:
            p = np.asarray(d.position_enu_m, dtype=float)
            weight = float(d.blob.area_px)
            best, best_gap = None, math.inf
            for spill in self.spills:
                distance = float(np.hypot(*(spill.position_enu_m[:2] - p[:2])))
                limit = max(self.merge_radius_m, spill.radius_m + d.radius_m)
                if distance <= limit and distance - limit < best_gap:
                    best, best_gap = spill, distance - limit
            if best is None:
                self.spills.append(Spill(p, d.radius_m, 1, weight))
                new += 1
                continue
            total = best.weight + weight
            best.position_enu_m = (best.position_enu_m * best.weight + p * weight) / total
            best.weight = total
            best.radius_m = max(best.radius_m, d.radius_m)
            best.detections += 1
        return new
