"""Geofence geometry: inclusion/exclusion polygons and circles from a fence plan.

A fence plan (mission_type 1) holds MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION/EXCLUSION items
(param1 = the polygon's vertex count, one item per vertex, consecutive), CIRCLE_INCLUSION/
EXCLUSION items (param1 = radius, m; a zero radius, which MAVSDK's geofence example sends as a
placeholder, encloses nothing and is ignored) and an optional NAV_FENCE_RETURN_POINT. As in PX4's
geofence (navigator/geofence.cpp): a position is inside the fence when it lies in none of the
exclusion areas and, if there are inclusion areas, in at least one of them. The shapes are
projected onto a local plane around the first vertex (metres), where shapely tests polygons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import shapely
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu import geodesy
from autopilot_emu.mission.items import GLOBAL_FRAMES, MissionItem

POLYGON_INCLUSION = mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
POLYGON_EXCLUSION = mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
CIRCLE_INCLUSION = mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION
CIRCLE_EXCLUSION = mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
RETURN_POINT = mavlink2.MAV_CMD_NAV_FENCE_RETURN_POINT
FENCE_COMMANDS = frozenset(
    {POLYGON_INCLUSION, POLYGON_EXCLUSION, CIRCLE_INCLUSION, CIRCLE_EXCLUSION, RETURN_POINT}
)


class FenceError(ValueError):
    """A fence plan that cannot be a fence; ``seq`` is the offending item."""

    def __init__(self, seq: int, message: str) -> None:
        super().__init__(f"fence item {seq}: {message}")
        self.seq = seq


@dataclass
class Fence:
    """The areas of one fence plan, in a local metric frame around ``origin``."""

    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Projection origin: latitude, longitude (deg), 0."""
    inclusion: list[shapely.Geometry] = field(default_factory=list)
    exclusion: list[shapely.Geometry] = field(default_factory=list)
    return_point: tuple[float, float, float] | None = None
    """NAV_FENCE_RETURN_POINT latitude, longitude (deg) and altitude (m, item frame)."""

    @property
    def empty(self) -> bool:
        """No inclusion or exclusion area."""
        return not self.inclusion and not self.exclusion

    def _point(self, lat_deg: float, lon_deg: float) -> shapely.Point:
        ned = geodesy.geodetic_to_ned(np.array([lat_deg, lon_deg, 0.0]), self.origin)
        return shapely.Point(float(ned[0]), float(ned[1]))

    def contains(self, lat_deg: float, lon_deg: float) -> bool:
        """Inside the fence: in no exclusion area and, if any exist, in an inclusion area."""
        if self.empty:
            return True
        point = self._point(lat_deg, lon_deg)
        # Exclusion areas are open (their boundary is allowed), inclusion areas closed.
        if any(area.contains(point) for area in self.exclusion):
            return False
        return not self.inclusion or any(area.covers(point) for area in self.inclusion)


def build_fence(items: tuple[MissionItem, ...]) -> Fence:
    """Parse a fence plan; raise :class:`FenceError` for a malformed one."""
    fence = Fence()
    seq = 0
    while seq < len(items):
        item = items[seq]
        if item.command not in FENCE_COMMANDS:
            raise FenceError(seq, f"command {item.command} is not a fence item")
        if item.frame not in GLOBAL_FRAMES:
            raise FenceError(seq, f"frame {item.frame} is not a global frame")
        if not (abs(item.x) <= 900_000_000 and abs(item.y) <= 1_800_000_000):
            raise FenceError(seq, "latitude or longitude out of range")
        if seq == 0:
            fence.origin = np.array([item.lat_deg, item.lon_deg, 0.0])
        if item.command == RETURN_POINT:
            fence.return_point = (item.lat_deg, item.lon_deg, item.z)
            seq += 1
        elif item.command in (CIRCLE_INCLUSION, CIRCLE_EXCLUSION):
            radius = item.params[0]
            if not (math.isfinite(radius) and radius >= 0):
                raise FenceError(seq, f"circle radius {radius} must not be negative")
            if radius > 0:  # a zero radius encloses nothing (MAVSDK's "no circle" placeholder)
                area = fence._point(item.lat_deg, item.lon_deg).buffer(radius, quad_segs=32)
                areas = fence.inclusion if item.command == CIRCLE_INCLUSION else fence.exclusion
                areas.append(area)
            seq += 1
        else:
            seq += _add_polygon(fence, items, seq)
    return fence


def _add_polygon(fence: Fence, items: tuple[MissionItem, ...], start: int) -> int:
    """Add the polygon starting at ``start``; return its vertex count."""
    first = items[start]
    count = first.params[0]
    if not (math.isfinite(count) and count == int(count) and count >= 3):
        raise FenceError(start, f"polygon vertex count {count} must be an integer >= 3")
    n = int(count)
    vertices = items[start : start + n]
    if len(vertices) < n or any(
        v.command != first.command or v.params[0] != count for v in vertices
    ):
        raise FenceError(start, f"polygon announces {n} vertices but has fewer")
    corners = [fence._point(v.lat_deg, v.lon_deg) for v in vertices]
    polygon = shapely.Polygon([(c.x, c.y) for c in corners])
    if not polygon.is_valid or polygon.area <= 0.0:
        raise FenceError(start, "polygon is self-intersecting or has no area")
    (fence.inclusion if first.command == POLYGON_INCLUSION else fence.exclusion).append(polygon)
    return n
