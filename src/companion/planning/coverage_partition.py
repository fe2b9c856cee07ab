"""The coverage role's lanes shared by seed 004's partitioners instead of in strips.

``coverage.split`` lays its lanes over the free area; with ``CoverageSpec.partition`` other than
"strips" this module shares them among K vehicles by region instead of by strip. Everything here
is in the sweep frame (the free area rotated so that the lanes run along +x, at the centres of
rows ``step`` apart from ``y_min``).

A lattice of square cells one lane step in size is laid over the free area, its rows centred on
the lanes. The cells a lane runs through (by a positive length) are the waypoints of a seed 004
``Grid``; the chosen partitioner labels them with K sub-areas (``mco``: the MCO extended Voronoi
tessellation, seed 004 Sec. 4.2.2; ``kmeans``: its K-means baseline; ``boustrophedon``: its
boustrophedon cell decomposition baseline, Choset & Pignon). Free cells no lane runs through
take the label of the nearest lane cell, so the K regions (the labelled cells' boxes cut to the
free area) tile the free area, and every region holds a lane. A region's lanes are the lanes'
pieces inside its cells, so no piece of lane belongs to two vehicles.

Pure: shapely geometry and numpy in, geometry out; no I/O. Deterministic: the partitioners'
random draws come from ``np.random.default_rng(PARTITION_SEED)``, so every vehicle, planning
alone from the same inputs, gets the same regions. Units: metres.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import shapely
from scipy.spatial import cKDTree
from shapely.geometry import LineString, Polygon, box
from shapely.geometry.base import BaseGeometry

from companion.planning.mco.boustrophedon import boustrophedon_partition
from companion.planning.mco.kmeans import kmeans_partition
from companion.planning.mco.partition import Partition, mco_partition
from companion.planning.mco.workspace import Grid, Workspace

LATTICE_PARTITIONS = ("mco", "kmeans", "boustrophedon")
"""Partitioners of seed 004 that ``lattice_regions`` can share the lanes with."""
PARTITION_SEED = 0
"""Seed of the partitioners' generator (MCO's circles, k-means++'s start): fixed, so that the
regions depend only on the geometry, the spec and K."""
_TOLERANCE_M = 1e-6
"""Shortest lane piece, m, and (squared, m^2) smallest cell area, that count."""

Region = tuple[BaseGeometry, tuple[tuple[LineString, ...], ...]]
"""A region of the free area (Polygon or MultiPolygon) and its lanes, first to last in y, each
a tuple of west-to-east segments; sweep frame."""


def lattice_regions(
    free: BaseGeometry,
    lanes: Sequence[Sequence[LineString]],
    y_min: float,
    step_m: float,
    k: int,
    method: str,
) -> list[Region]:
    """The free area and its lanes shared among ``k`` >= 2 vehicles by partitioner ``method``.

    Args:
        free: the free area, sweep frame (lanes along +x).
        lanes: the pieces of lane i (possibly none) at y = y_min + (i + 1/2) step, i = 0, 1, ...
        y_min: south edge of the free area, m.
        step_m: distance between neighbouring lanes, m; the lattice's cell size.
        k: number of vehicles.
        method: one of ``LATTICE_PARTITIONS``.

    Returns the K regions ordered by their centroid's y (then x): region j lies about where
    strip j would, so the order matches "strips".

    Raises:
        ValueError: ``method`` unknown, or the partitioner cannot make K sub-areas of the lane
            cells (fewer lane cells than K, fewer boustrophedon cells than K); names k and method.
    """
    if method not in LATTICE_PARTITIONS:
        raise ValueError(f"partition must be one of {LATTICE_PARTITIONS}, got {method!r}")
    x_min, _, x_max, _ = free.bounds
    n_row, n_col = len(lanes), max(1, math.ceil((x_max - x_min) / step_m - 1e-9))
    rows, cols = (a.ravel() for a in np.meshgrid(np.arange(n_row), np.arange(n_col), indexing="ij"))
    left = x_min + cols * step_m
    cells = shapely.box(left, y_min + rows * step_m, left + step_m, y_min + (rows + 1) * step_m)
    in_free = shapely.area(shapely.intersection(cells, free)) > _TOLERANCE_M**2
    lane_length = _lane_length(lanes, x_min, step_m, n_col).ravel()
    on_lane = lane_length > _TOLERANCE_M
    centres = np.column_stack((left + step_m / 2.0, y_min + (rows + 0.5) * step_m))
    grid = Grid(
        waypoints_xy_m=centres[on_lane],
        row=rows[on_lane].astype(np.int64),
        col=cols[on_lane].astype(np.int64),
        cell_m=(step_m, step_m),
        origin_xy_m=(x_min + step_m / 2.0, y_min + step_m / 2.0),
        zli_cells=0,
        hole_cells=0,
    )
    frame = box(x_min, y_min, x_min + n_col * step_m, y_min + n_row * step_m)
    try:
        labels = _label(grid, free, frame, k, method)
    except ValueError as err:
        raise ValueError(f"partition {method!r} among k={k} vehicles: {err}") from err
    cell_label = np.full(len(cells), -1, dtype=np.int64)
    cell_label[on_lane] = labels
    rest = np.flatnonzero(in_free & ~on_lane)
    if len(rest):
        cell_label[rest] = labels[cKDTree(grid.waypoints_xy_m).query(centres[rest])[1]]
    regions = []
    for j in range(k):
        mine = cell_label == j
        polygon = _polygonal(shapely.union_all(cells[mine]).intersection(free))
        own_lanes = tuple(
            segments
            for r in range(n_row)
            if (segments := _cut(lanes[r], x_min, step_m, cols[mine & (rows == r)]))
        )
        if not own_lanes or polygon.is_empty:
            raise ValueError(f"partition {method!r} among k={k} vehicles left region {j} no lane")
        regions.append((polygon, own_lanes))
    return sorted(regions, key=lambda g: (g[0].centroid.y, g[0].centroid.x))


def _label(grid: Grid, free: BaseGeometry, frame: Polygon, k: int, method: str) -> np.ndarray:
    """The partitioner's sub-area (0..k-1) of each grid waypoint."""
    rng = np.random.default_rng(PARTITION_SEED)
    outside = _polygonal(frame.difference(free))
    # The workspace: the lattice's box, what is not free a zone of low interest (the free area
    # may be several polygons, which a Workspace polygon cannot be).
    workspace = Workspace(polygon=frame, zli=tuple(getattr(outside, "geoms", [outside])))
    partition: Partition
    if method == "mco":
        partition = mco_partition(grid, workspace, k, rng)
    elif method == "kmeans":
        partition = kmeans_partition(grid, k, rng)
    else:
        # Choset's cells are swept by a line parallel to the lanes (a cell's slices are unbroken
        # lanes); boustrophedon_cells sweeps a north-south line, so it is given x and y swapped.
        swapped = Workspace(
            polygon=_swap(workspace.polygon), zli=tuple(_swap(z) for z in workspace.zli)
        )
        flipped = dataclasses.replace(grid, waypoints_xy_m=grid.waypoints_xy_m[:, ::-1].copy())
        partition = boustrophedon_partition(flipped, swapped, k)
    return partition.labels


def _swap(geometry: BaseGeometry) -> BaseGeometry:
    """``geometry`` with x and y exchanged."""
    return shapely.transform(geometry, lambda xy: xy[:, ::-1])


def _lane_length(
    lanes: Sequence[Sequence[LineString]], x_min: float, step_m: float, n_col: int
) -> np.ndarray:
    """(rows, n_col) length of lane inside each cell, m."""
    left = x_min + np.arange(n_col) * step_m
    out = np.zeros((len(lanes), n_col))
    for r, pieces in enumerate(lanes):
        for piece in pieces:
            a, b = sorted((piece.coords[0][0], piece.coords[-1][0]))
            out[r] += np.clip(np.minimum(b, left + step_m) - np.maximum(a, left), 0.0, None)
    return out


def _cut(
    pieces: Sequence[LineString], x_min: float, step_m: float, cols: np.ndarray
) -> tuple[LineString, ...]:
    """The parts of one lane's pieces inside the given cells of its row, west to east."""
    out = []
    cols = np.sort(cols)
    starts = cols[np.r_[True, np.diff(cols) > 1]] if len(cols) else cols
    ends = cols[np.r_[np.diff(cols) > 1, True]] if len(cols) else cols
    for piece in pieces:
        a, b = sorted((piece.coords[0][0], piece.coords[-1][0]))
        y = piece.coords[0][1]
        for c0, c1 in zip(starts, ends, strict=True):
            lo, hi = max(a, x_min + c0 * step_m), min(b, x_min + (c1 + 1) * step_m)
            if hi - lo > _TOLERANCE_M:
                out.append(LineString([(lo, y), (hi, y)]))
    return tuple(sorted(out, key=lambda s: s.coords[0][0]))


def _polygonal(geometry: BaseGeometry) -> BaseGeometry:
    """The polygons of positive area of ``geometry``, as one Polygon or MultiPolygon."""
    flat = shapely.get_parts(shapely.get_parts(geometry))  # a collection may hold multi-parts
    parts = [p for p in flat if isinstance(p, Polygon) and p.area > 0.0]
    if not parts:
        return Polygon()
    return parts[0] if len(parts) == 1 else shapely.MultiPolygon(parts)
