"""Planner maps from a :class:`~worlds.model.World` alone: polygons, free space, grids, graphs.

Companion code may import these (``worlds`` is a leaf package); they see what a planner with a
perfect map sees at one altitude and one simulation time. ``altitude_m=None`` means "every solid
blocks" (a 2-D planner); a number keeps only the solids whose vertical extent contains it, so
overhead pipes do not block a vehicle flying under them and a 20 m building does not block at 50 m.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import networkx as nx
import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from worlds.model import World


def obstacle_polygons(
    world: World, altitude_m: float | None = None, t_s: float = 0.0, include_no_fly: bool = True
) -> list[shapely.Polygon]:
    """Footprints of the solids blocking at ``altitude_m`` and time ``t_s``, plus no-fly zones."""
    out = []
    for solid in world.solids:
        if altitude_m is not None:
            bottom, top = solid.z_range_at(t_s)
            if not bottom <= altitude_m <= top:
                continue
        out.append(solid.footprint_at(t_s))
    if include_no_fly:
        out.extend(world.no_fly)
    return out


def free_space(
    world: World, altitude_m: float | None = None, t_s: float = 0.0, clearance_m: float = 0.0
) -> BaseGeometry:
    """Where a vehicle's centre may be: the boundary minus obstacles, grown by ``clearance_m``."""
    if clearance_m < 0 or not math.isfinite(clearance_m):
        raise ValueError(f"clearance_m must be finite and >= 0, got {clearance_m}")
    blocked = shapely.union_all(obstacle_polygons(world, altitude_m, t_s))
    area = world.boundary.buffer(-clearance_m) if clearance_m > 0 else world.boundary
    return area.difference(blocked.buffer(clearance_m) if clearance_m > 0 else blocked)


def occupancy_grid(
    world: World,
    resolution_m: float,
    altitude_m: float | None = None,
    t_s: float = 0.0,
    clearance_m: float = 0.0,
) -> tuple[np.ndarray, tuple[float, float], float]:
    """Rasterise the world: ``grid[row, col]`` is True where the cell centre is not in free space.

    Returns ``(grid, origin_xy_m, resolution_m)``: row ``r``, column ``c`` has its centre at
    ``origin + ((c + 0.5) * resolution_m, (r + 0.5) * resolution_m)``; the grid covers the world's
    extent. Vectorised with shapely's ``contains_xy``.
    """
    if not resolution_m > 0 or not math.isfinite(resolution_m):
        raise ValueError(f"resolution_m must be finite and > 0, got {resolution_m}")
    x0, y0, x1, y1 = world.bounds_xy_m
    nx_cells = max(1, math.ceil((x1 - x0) / resolution_m - 1e-9))
    ny_cells = max(1, math.ceil((y1 - y0) / resolution_m - 1e-9))
    xs = x0 + (np.arange(nx_cells) + 0.5) * resolution_m
    ys = y0 + (np.arange(ny_cells) + 0.5) * resolution_m
    gx, gy = np.meshgrid(xs, ys)
    free = free_space(world, altitude_m, t_s, clearance_m)
    shapely.prepare(free)
    grid = ~shapely.contains_xy(free, gx, gy)
    return grid, (x0, y0), resolution_m


def cell_of(
    xy_m: tuple[float, float], origin_xy_m: tuple[float, float], resolution_m: float
) -> tuple[int, int]:
    """The (row, col) of the grid cell holding point ``xy_m``."""
    return (
        math.floor((xy_m[1] - origin_xy_m[1]) / resolution_m),
        math.floor((xy_m[0] - origin_xy_m[0]) / resolution_m),
    )


def grid_graph(
    world: World,
    resolution_m: float,
    altitude_m: float | None = None,
    t_s: float = 0.0,
    clearance_m: float = 0.0,
) -> nx.Graph:
    """Free cells as nodes ``(row, col)`` with ``pos`` (x, y) in m, 8-connected, ``weight`` in m.

    A diagonal edge needs both cells beside it free too (no cutting corners through walls). The
    graph's ``origin_xy_m`` and ``resolution_m`` attributes map points to nodes
    with :func:`cell_of`.
    """
    grid, origin, res = occupancy_grid(world, resolution_m, altitude_m, t_s, clearance_m)
    free = ~grid
    graph = nx.Graph(origin_xy_m=origin, resolution_m=res)
    rows, cols = np.nonzero(free)
    xs = origin[0] + (cols + 0.5) * res
    ys = origin[1] + (rows + 0.5) * res
    graph.add_nodes_from(
        ((int(r), int(c)), {"pos": (float(x), float(y))})
        for r, c, x, y in zip(rows, cols, xs, ys, strict=True)
    )
    ny, nx_ = free.shape
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        c_lo, c_hi = max(0, -dc), nx_ - max(0, dc)
        a = free[0 : ny - dr, c_lo:c_hi]
        b = free[dr:ny, c_lo + dc : c_hi + dc]
        ok = a & b
        if dr and dc:
            ok &= free[0 : ny - dr, c_lo + dc : c_hi + dc] & free[dr:ny, c_lo:c_hi]
        r, c = np.nonzero(ok)
        c = c + c_lo
        w = res * math.hypot(dr, dc)
        graph.add_weighted_edges_from(
            ((int(i), int(j)), (int(i) + dr, int(j) + dc), w) for i, j in zip(r, c, strict=True)
        )
    return graph


def visibility_graph(
    world: World,
    altitude_m: float | None = None,
    t_s: float = 0.0,
    clearance_m: float = 0.0,
    points_xy_m: Sequence[tuple[float, float]] = (),
) -> nx.Graph:
    """Corners of the free space plus ``points_xy_m``, joined where the straight segment is free.

    Nodes are integers with ``pos`` (x, y) in m; the given points come first (nodes 0, 1, ...), so
    a planner asks ``nx.shortest_path(g, 0, 1, weight="weight")`` from start 0 to goal 1. Edges hold
    their length as ``weight``. Cost grows with the square of the corner count (cylinders have 32
    corners): meant for worlds of tens of obstacles; use :func:`grid_graph` for dense ones.
    """
    free = free_space(world, altitude_m, t_s, clearance_m)
    rings = []
    for part in getattr(free, "geoms", [free]):
        if isinstance(part, shapely.Polygon) and not part.is_empty:
            rings.append(part.exterior)
            rings.extend(part.interiors)
    corners = [np.asarray(ring.coords)[:-1] for ring in rings]
    given = np.asarray(points_xy_m, dtype=float).reshape(-1, 2)
    xy = np.vstack([given, *corners]) if corners else given
    graph = nx.Graph()
    graph.add_nodes_from((i, {"pos": (float(x), float(y))}) for i, (x, y) in enumerate(xy))
    if len(xy) < 2:
        return graph
    i, j = np.triu_indices(len(xy), k=1)
    segments = shapely.linestrings(np.stack([xy[i], xy[j]], axis=1))
    tolerant = free.buffer(1e-6)
    shapely.prepare(tolerant)
    ok = shapely.covers(tolerant, segments)
    lengths = np.hypot(*(xy[j] - xy[i]).T)
    graph.add_weighted_edges_from(
        (int(a), int(b), float(w)) for a, b, w in zip(i[ok], j[ok], lengths[ok], strict=True)
    )
    return graph
