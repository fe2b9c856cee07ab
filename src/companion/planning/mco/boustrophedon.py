"""Seed 004's polygonal baseline: the boustrophedon cell decomposition (Sec. 4.2.2 and 5).

Choset & Pignon, "Coverage path planning: the boustrophedon cellular decomposition" (FSR 1997 /
1998): a vertical line sweeps the free space (polygon minus holes minus ZLIs) west to east; a
cell ends and new ones start at a critical point, where the number of connected pieces of the
sweep line's slice changes. Discretely: the free space is cut into slabs between consecutive
vertex x-coordinates; a slab's piece continues the cell of the previous slab's piece when the two
touch one-to-one, and starts a new cell otherwise.
"""

from __future__ import annotations

import itertools

import numpy as np
import shapely
from shapely.geometry import Polygon, box
from shapely.geometry.base import BaseGeometry

from companion.planning.mco.partition import Partition, check_n
from companion.planning.mco.workspace import Grid, Workspace, default_takeoff_xy_m

_TOUCH_M = 1e-9
"""Shortest shared edge, m, for two pieces of neighbouring slabs to count as continuing."""


def _polygons(geometry: BaseGeometry) -> list[Polygon]:
    """The polygons of ``geometry`` with positive area."""
    parts = getattr(geometry, "geoms", [geometry])
    return [p for p in parts if isinstance(p, Polygon) and p.area > 0.0]


def free_space(workspace: Workspace) -> BaseGeometry:
    """The polygon minus its holes minus every ZLI."""
    if not workspace.zli:
        return workspace.polygon
    return workspace.polygon.difference(shapely.union_all(list(workspace.zli)))


def boustrophedon_cells(workspace: Workspace) -> list[Polygon]:
    """Boustrophedon cells of the free space, vertical sweep, west to east (Choset & Pignon)."""
    free = free_space(workspace)
    rings = []
    for poly in _polygons(free):
        rings.append(poly.exterior)
        rings.extend(poly.interiors)
    xs = np.unique(np.round(np.concatenate([np.asarray(r.coords)[:, 0] for r in rings]), 9))
    _, y0, _, y1 = free.bounds
    cells: list[list[Polygon]] = []
    previous: list[tuple[Polygon, int]] = []  # (piece, cell index) of the previous slab
    for left, right in itertools.pairwise(xs):
        pieces = _polygons(free.intersection(box(left, y0 - 1.0, right, y1 + 1.0)))
        touch = [
            [j for j, (prev, _) in enumerate(previous) if _shared(prev, piece)] for piece in pieces
        ]
        current: list[tuple[Polygon, int]] = []
        for piece, prevs in zip(pieces, touch, strict=True):
            one_to_one = len(prevs) == 1 and sum(prevs[0] in t for t in touch) == 1
            if one_to_one:
                index = previous[prevs[0]][1]
                cells[index].append(piece)
            else:  # a critical point: the slice's connectivity changed
                index = len(cells)
                cells.append([piece])
            current.append((piece, index))
        previous = current
    out = []
    for pieces in cells:
        merged = shapely.union_all(pieces)
        out.extend(_polygons(merged) if merged.geom_type != "Polygon" else [merged])
    return out


def _shared(a: Polygon, b: Polygon) -> bool:
    """Whether two pieces of neighbouring slabs share an edge of positive length."""
    return a.intersection(b).length > _TOUCH_M


def _cell_labels(grid: Grid, cells: list[Polygon]) -> np.ndarray:
    """Index of the cell holding each waypoint (first one on a shared edge; nearest if none)."""
    x, y = grid.waypoints_xy_m[:, 0], grid.waypoints_xy_m[:, 1]
    labels = np.full(len(x), -1, dtype=np.int64)
    for index, cell in enumerate(cells):
        hit = (labels < 0) & shapely.intersects_xy(cell, x, y)
        labels[hit] = index
    for i in np.flatnonzero(labels < 0):
        point = shapely.Point(x[i], y[i])
        labels[i] = int(np.argmin([cell.distance(point) for cell in cells]))
    return labels


def boustrophedon_cell_count(grid: Grid, workspace: Workspace) -> int:
    """Number of boustrophedon cells holding at least one waypoint (seed 004's largest n)."""
    labels = _cell_labels(grid, boustrophedon_cells(workspace))
    return int(np.unique(labels).size)


def boustrophedon_partition(
    grid: Grid,
    workspace: Workspace,
    n: int,
    takeoff_xy_m: np.ndarray | None = None,
) -> Partition:
    """Seed 004's boustrophedon baseline: ``n`` sub-areas from the workspace's cells.

    Waypoints take the cell holding them; cells without a waypoint are dropped. While more than n
    cells remain, the smallest (fewest waypoints, lowest index on a tie) is merged into the
    touching cell with fewest waypoints (our choice; the paper lets the decomposition fix n). A
    cell touching none merges into the nearest. Sites are the waypoint centroids of the sub-areas.
    """
    check_n(n, len(grid))
    cells = boustrophedon_cells(workspace)
    labels = _cell_labels(grid, cells)
    kept = np.unique(labels)
    geoms = [cells[i] for i in kept]
    labels = np.searchsorted(kept, labels)
    if len(geoms) < n:
        raise ValueError(
            f"the workspace's boustrophedon decomposition has {len(geoms)} cells; n={n} exceeds it"
        )
    while len(geoms) > n:
        counts = np.bincount(labels, minlength=len(geoms))
        small = int(np.argmin(counts))
        others = [i for i in range(len(geoms)) if i != small]
        touching = [i for i in others if geoms[small].intersects(geoms[i])]
        if touching:
            into = min(touching, key=lambda i: (counts[i], i))
        else:
            into = min(others, key=lambda i: (geoms[small].distance(geoms[i]), i))
        geoms[into] = shapely.union_all([geoms[into], geoms[small]])
        labels[labels == small] = into
        del geoms[small]
        labels[labels > small] -= 1
    sites = np.array([grid.waypoints_xy_m[labels == i].mean(axis=0) for i in range(n)])
    p0 = default_takeoff_xy_m(grid) if takeoff_xy_m is None else np.asarray(takeoff_xy_m, float)
    return Partition(labels, sites, p0.reshape(1, 2), "boustrophedon")
