"""Outlines the generators share: the world's centred rectangle, irregular blobs (spills, zones)."""

from __future__ import annotations

import numpy as np
from shapely.geometry import Polygon, box


def centred_rectangle(size_x_m: float, size_y_m: float) -> Polygon:
    """The rectangle of a world's extent, centred on the origin (the worlds' ENU frame)."""
    return box(-size_x_m / 2.0, -size_y_m / 2.0, size_x_m / 2.0, size_y_m / 2.0)


def irregular_outline(
    rng: np.random.Generator,
    center_xy: tuple[float, float],
    radius_m: float,
    vertices: int = 14,
    jitter: float = 0.35,
) -> Polygon:
    """A star-shaped blob around ``center_xy``: sorted random angles, smoothed random radii.

    Radii are ``radius_m * (1 + jitter * n)`` with ``n`` a circularly smoothed noise in [-1, 1],
    so the outline is irregular but never self-intersecting.
    """
    angles = np.sort(rng.uniform(0.0, 2.0 * np.pi, vertices))
    noise = rng.uniform(-1.0, 1.0, vertices)
    smooth = (np.roll(noise, 1) + 2.0 * noise + np.roll(noise, -1)) / 4.0
    radii = radius_m * (1.0 + jitter * smooth)
    xs = center_xy[0] + radii * np.cos(angles)
    ys = center_xy[1] + radii * np.sin(angles)
    poly = Polygon(np.column_stack([xs, ys]))
    return poly if poly.is_valid else poly.convex_hull
