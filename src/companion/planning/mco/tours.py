"""Coverage tours of a sub-area's waypoints: length, nearest neighbour, 2-opt and the zigzag.

Seed 004, Sec. 4.2.4: each sub-area's free cells (cell centres, the waypoints) are visited by one
tour that leaves the start and comes back to it (a TSP). The Firefly tour is in
:mod:`companion.planning.mco.firefly`; these are its baselines: the zigzag (boustrophedon) sweep
of Sec. 5.2 and the classical nearest-neighbour + 2-opt heuristic.
"""

from __future__ import annotations

import numpy as np


def _points(points_xy: np.ndarray) -> np.ndarray:
    """``points_xy`` as a finite ``(K, 2)`` float array."""
    pts = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    if not np.isfinite(pts).all():
        raise ValueError("points_xy must be finite")
    return pts


def _start(start_xy: np.ndarray) -> np.ndarray:
    """``start_xy`` as a finite ``(2,)`` float array."""
    start = np.asarray(start_xy, dtype=float)
    if start.shape != (2,) or not np.isfinite(start).all():
        raise ValueError(f"start_xy must be a finite (2,) point, got {start_xy!r}")
    return start


def tour_length_m(
    points_xy: np.ndarray, order: np.ndarray, start_xy: np.ndarray | None = None
) -> float:
    """Length of the path through ``points_xy[order]``, m.

    With ``start_xy`` the tour is closed: start -> points in order -> start. Without it, the open
    path from the first point of ``order`` to its last.
    """
    pts = _points(points_xy)[np.asarray(order, dtype=np.int64)]
    if start_xy is not None:
        start = _start(start_xy)[None, :]
        pts = np.concatenate([start, pts, start])
    if len(pts) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def nearest_neighbour_order(points_xy: np.ndarray, start_xy: np.ndarray) -> np.ndarray:
    """Greedy tour: from the start, always the nearest unvisited point (ties: lower index)."""
    pts = _points(points_xy)
    here = _start(start_xy)
    left = np.ones(len(pts), dtype=bool)
    order = np.empty(len(pts), dtype=np.int64)
    for k in range(len(pts)):
        gap = np.where(left, np.linalg.norm(pts - here, axis=1), np.inf)
        order[k] = int(np.argmin(gap))
        left[order[k]] = False
        here = pts[order[k]]
    return order


def two_opt(points_xy: np.ndarray, order: np.ndarray, start_xy: np.ndarray) -> np.ndarray:
    """2-opt descent of the closed tour start -> points[order] -> start; the improved order.

    Each step applies the segment reversal that shortens the tour most (all moves scored at once
    with numpy), until none shortens it by more than 1e-9 of its length. Never lengthens.
    """
    pts = _points(points_xy)
    tour = np.asarray(order, dtype=np.int64).copy()
    if sorted(tour.tolist()) != list(range(len(pts))):
        raise ValueError("order must be a permutation of the points' indices")
    nodes = np.concatenate([_start(start_xy)[None, :], pts])
    dist = np.linalg.norm(nodes[:, None, :] - nodes[None, :, :], axis=2)
    k = len(tour)
    if k < 3:
        return tour
    i, j = np.triu_indices(k, 1)  # reverse tour[i..j] (positions in the order, 0-based)
    while True:
        cycle = np.concatenate([[0], tour + 1, [0]])  # node ids, start at both ends
        before, first, last, after = cycle[i], cycle[i + 1], cycle[j + 1], cycle[j + 2]
        gain = dist[before, first] + dist[last, after] - dist[before, last] - dist[first, after]
        best = int(np.argmax(gain))
        if gain[best] <= 1e-9 * max(dist[cycle[:-1], cycle[1:]].sum(), 1.0):
            return tour
        tour[i[best] : j[best] + 1] = tour[i[best] : j[best] + 1][::-1].copy()


def zigzag_order(
    points_xy: np.ndarray, row: np.ndarray, col: np.ndarray, start_xy: np.ndarray
) -> np.ndarray:
    """The zigzag (boustrophedon) sweep over a sub-area's cells (Sec. 5.2, seed 004).

    Cells are swept row by row (``row``: each point's grid row index), along each row by ``col``,
    the direction alternating from one non-empty row to the next. It starts at whichever of the
    four ends (first or last row, its lowest or highest column) lies nearest ``start_xy``.
    Only the sub-area's own cells are waypoints: ZLI cells (not in ``points_xy``) are flown over
    within a row, never stopped at (P2; digest Sec. 6 item 9).
    """
    pts = _points(points_xy)
    rows = np.asarray(row, dtype=np.int64)
    cols = np.asarray(col, dtype=np.int64)
    if rows.shape != (len(pts),) or cols.shape != (len(pts),):
        raise ValueError(f"row and col must have shape ({len(pts)},)")
    start = _start(start_xy)
    if len(pts) == 0:
        return np.zeros(0, dtype=np.int64)
    lines = [np.flatnonzero(rows == r) for r in np.unique(rows)]
    lines = [line[np.lexsort((line, cols[line]))] for line in lines]  # by col, then index
    ends = [(0, False), (0, True), (len(lines) - 1, False), (len(lines) - 1, True)]

    def gap(end: tuple[int, bool]) -> float:
        line = lines[end[0]]
        return float(np.linalg.norm(pts[line[-1] if end[1] else line[0]] - start))

    first_row, reverse = min(ends, key=gap)  # ties: first row, then lowest column
    if first_row:
        lines = lines[::-1]
    out = []
    for line in lines:
        out.append(line[::-1] if reverse else line)
        reverse = not reverse
    return np.concatenate(out)


def straight_legs(path_xy: np.ndarray, tolerance_m: float = 0.01) -> np.ndarray:
    """The corners of a path: points where it turns, its first and its last.

    A waypoint in the middle of a straight leg (a lane of cell centres) is dropped: the vehicle
    flies the leg at speed instead of passing a mission item every cell, and the camera triggers
    by distance along it, so the coverage is the same. A point is kept when it lies more than
    ``tolerance_m`` off the line from the last kept corner to the next point, or when the path
    reverses there.
    """
    pts = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    if len(pts) <= 2:
        return pts.copy()
    keep = [0]
    for k in range(1, len(pts) - 1):
        a, b, c = pts[keep[-1]], pts[k], pts[k + 1]
        ab, bc = b - a, c - b
        span = float(np.hypot(*(c - a)))
        cross = abs(float(ab[0] * bc[1] - ab[1] * bc[0]))
        if span <= 0.0 or cross / span > tolerance_m or float(ab @ bc) <= 0.0:
            keep.append(k)
    keep.append(len(pts) - 1)
    return pts[keep]
