"""Where vehicles start in a world: spawn points inside a launch area, and each kind's default area.

Pure geometry (no simulator): ``spawn_points`` lays n vehicles out on a hexagonal lattice of
``spacing_m`` around the area's centre, nearest points first, so one vehicle stands on the centre
and a swarm fills the pad ring by ring; ``default_area`` picks the area a kind launches from.
"""

from __future__ import annotations

import math

import shapely
from shapely.ops import nearest_points

from worlds.maps import free_space
from worlds.model import XYZ, LaunchArea, World

DEFAULT_AREA_NAMES = ("helideck", "land_base", "safe_point", "start", "agent_start_0")
"""Launch areas ``default_area`` prefers, in order (offshore, city, indoor, arena, task map)."""
ORIGIN_AREA_RADIUS_M = 50.0
"""Largest radius of the ``origin`` area made up for a world without launch areas, m."""


def spawn_points(area: LaunchArea, n: int, spacing_m: float) -> list[XYZ]:
    """The n (east, north, surface_z) points inside ``area``, at least ``spacing_m`` apart.

    The points are the hexagonal lattice of side ``spacing_m`` centred on the area's centre,
    nearest the centre first (ties counter-clockwise from east), within ``area.radius_m``;
    surface_z is the area's height (a helideck's deck). Deterministic, no random draw.

    Raises:
        ValueError: n < 1, spacing_m not positive, or the area cannot hold n points (the message
            names the area, its radius and n).
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"n must be an int >= 1, got {n!r}")
    if not (math.isfinite(spacing_m) and spacing_m > 0.0):
        raise ValueError(f"spacing_m must be positive, got {spacing_m!r}")
    cx, cy, cz = area.center_enu_m
    if n == 1:
        return [(float(cx), float(cy), float(cz))]
    k = int(area.radius_m / spacing_m / (math.sqrt(3.0) / 2.0)) + 1
    offsets = []
    for j in range(-k, k + 1):
        for i in range(-2 * k, 2 * k + 1):
            x = spacing_m * (i + j / 2.0)
            y = spacing_m * j * math.sqrt(3.0) / 2.0
            r = math.hypot(x, y)
            if r <= area.radius_m + 1e-9:
                angle = math.atan2(y, x) % (2.0 * math.pi)
                offsets.append((round(r / spacing_m, 6), round(angle, 9), x, y))
    offsets.sort()
    if len(offsets) < n:
        raise ValueError(
            f"launch area {area.name!r} (radius {area.radius_m:g} m) cannot hold {n} vehicles "
            f"{spacing_m:g} m apart (room for {len(offsets)}); use fewer vehicles or a smaller "
            "spacing"
        )
    return [(float(cx + x), float(cy + y), float(cz)) for _, _, x, y in offsets[:n]]


def default_area(world: World) -> LaunchArea:
    """The launch area a world's vehicles start from when none is named.

    The first of ``DEFAULT_AREA_NAMES`` the world has (helideck, land_base, safe_point, start,
    agent_start_0), else its first launch area. A world without any (``workspace_mco``) gets an
    ``origin`` area made up here: centred on the free point nearest the origin, its radius the
    distance from there to the nearest obstacle or boundary (at most ORIGIN_AREA_RADIUS_M).
    """
    names = [area.name for area in world.launch_areas]
    for name in DEFAULT_AREA_NAMES:
        if name in names:
            return world.launch_area(name)
    if world.launch_areas:
        return world.launch_areas[0]
    free = free_space(world)
    if free.is_empty:
        raise ValueError(f"world {world.kind!r} has no launch area and no free space to start in")
    origin = shapely.Point(0.0, 0.0)
    point = origin if free.contains(origin) else nearest_points(free, origin)[0]
    if not free.contains(point):  # on the edge: step inside
        point = free.representative_point()
    radius = min(ORIGIN_AREA_RADIUS_M, float(free.boundary.distance(point)))
    return LaunchArea("origin", (float(point.x), float(point.y), 0.0), radius)
