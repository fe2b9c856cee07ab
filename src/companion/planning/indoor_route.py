"""Room-visiting routes through an indoor world: rooms, their split among vehicles, clear paths.

Pure geometry on a :class:`worlds.World` (no I/O, no simulator): the rooms are the holes of the
walls once their doorways are closed; the free space is the world's boundary minus every solid
reaching below the flight height, both kept ``margin_m`` away; paths are shortest paths on a
grid of that free space (8-connected, no corner cutting; scipy's Dijkstra), shortened where a
straight segment stays in it. The rooms are split among K vehicles so that the longest closed
tour from the shared reference point (the launch area's centre) is shortest; every vehicle
computes the same split from the same inputs, so the parts fit together without talking to
each other.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.ops import nearest_points

from worlds.model import World

EXACT_SPLIT_MAX_ROOMS = 12
"""Up to this many rooms the split is exact (tours by Held-Karp, partitions over subsets);
more rooms are cut into consecutive runs of one nearest-neighbour tour."""


@dataclass(frozen=True)
class RouteSpec:
    """How the planner sees the world, SI units."""

    altitude_m: float = 1.5
    """Flight height above the floor, m: solids whose bottom is below it + ``margin_m`` block
    (overhead pipes higher up do not)."""
    margin_m: float = 0.55
    """Horizontal distance kept from walls, machinery and the boundary, m; less than half the
    narrowest doorway, or no path leads through it."""
    resolution_m: float = 0.25
    """Grid cell size, m; at most ``doorway_width - 2 margin`` so that a doorway keeps a cell."""
    door_close_m: float = 1.0
    """Walls grown by this much close their doorways (up to twice as wide) to find the rooms, m."""

    def __post_init__(self) -> None:
        for name in ("altitude_m", "margin_m", "resolution_m", "door_close_m"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")


@dataclass(frozen=True)
class Room:
    """One room: its outline and the free point the route visits (nearest its centre)."""

    index: int
    outline: Polygon
    goal_xy_m: tuple[float, float]


@dataclass(frozen=True)
class Route:
    """One vehicle's route: the rooms in visiting order and the waypoints, world ENU m."""

    rooms: tuple[int, ...]
    """Indices (into :attr:`IndoorPlanner.rooms`) of the rooms visited, in order."""
    waypoints_xy_m: np.ndarray
    """(M, 2) east, north: from the start through every room's goal and back to the start."""
    room_waypoint: tuple[int, ...]
    """Index into ``waypoints_xy_m`` of each visited room's goal."""

    @property
    def length_m(self) -> float:
        """Length of the polyline, m."""
        return polyline_length(self.waypoints_xy_m)


def polyline_length(points_xy_m: np.ndarray) -> float:
    """Length of a polyline (M, 2), m."""
    pts = np.asarray(points_xy_m, dtype=float).reshape(-1, 2)
    return float(np.hypot(*np.diff(pts, axis=0).T).sum()) if len(pts) > 1 else 0.0


def blocking_footprints(world: World, altitude_m: float, clearance_m: float) -> list[Polygon]:
    """Footprints of the solids reaching below ``altitude_m + clearance_m`` (static, t = 0)."""
    return [
        s.footprint_at(0.0) for s in world.solids if s.z_range_at(0.0)[0] < altitude_m + clearance_m
    ] + list(world.no_fly)


def find_rooms(world: World, door_close_m: float = 1.0) -> list[Polygon]:
    """The rooms: holes of the union of the solids named ``wall`` with their doorways closed.

    Growing the walls by ``door_close_m`` closes every gap narrower than twice that; each hole
    left is a room (shrunk), grown back by the same amount. Sorted south to north, then west to
    east (deterministic). A world without walls has none.
    """
    walls = [s.footprint_at(0.0) for s in world.solids if s.name == "wall"]
    if not walls:
        return []
    closed = shapely.union_all(walls).buffer(door_close_m, join_style="mitre")
    holes = []
    for part in getattr(closed, "geoms", [closed]):
        for ring in part.interiors:
            hole = Polygon(ring).buffer(door_close_m, join_style="mitre")
            holes.append(hole)
    return sorted(holes, key=lambda p: (round(p.centroid.y, 3), round(p.centroid.x, 3)))


class IndoorPlanner:
    """Free space, grid graph and rooms of one world at one flight height."""

    def __init__(self, world: World, spec: RouteSpec = RouteSpec()) -> None:
        self.world = world
        self.spec = spec
        blocked = shapely.union_all(blocking_footprints(world, spec.altitude_m, spec.margin_m))
        self.free: BaseGeometry = world.boundary.buffer(-spec.margin_m).difference(
            blocked.buffer(spec.margin_m)
        )
        """Where the vehicle's centre may be, the margin kept."""
        self._tolerant = self.free.buffer(1e-6)
        shapely.prepare(self._tolerant)
        self._graph, self._origin, self._shape = self._grid()
        self._cells = np.flatnonzero(self._free_cells.ravel())
        """Flat grid index of each graph node (node k is cell ``_cells[k]``)."""
        self._node_xy = self._xy(self._cells)
        self._paths: dict[tuple, np.ndarray] = {}
        self._trees: dict[int, np.ndarray] = {}

    # -- grid ----------------------------------------------------------------------------------
    def _grid(self) -> tuple[csr_matrix, tuple[float, float], tuple[int, int]]:
        """Free cells as a sparse graph: 8-connected, edge weights in m, no corner cutting."""
        res = self.spec.resolution_m
        x0, y0, x1, y1 = self.world.bounds_xy_m
        nx_cells = max(1, math.ceil((x1 - x0) / res - 1e-9))
        ny_cells = max(1, math.ceil((y1 - y0) / res - 1e-9))
        xs = x0 + (np.arange(nx_cells) + 0.5) * res
        ys = y0 + (np.arange(ny_cells) + 0.5) * res
        gx, gy = np.meshgrid(xs, ys)
        shapely.prepare(self.free)
        free = shapely.contains_xy(self.free, gx, gy)
        self._free_cells = free
        node_of = np.full(free.shape, -1, dtype=np.int64)
        node_of[free] = np.arange(int(free.sum()))
        rows, cols, weights = [], [], []
        ny, nxc = free.shape
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            c_lo, c_hi = max(0, -dc), nxc - max(0, dc)
            ok = free[0 : ny - dr, c_lo:c_hi] & free[dr:ny, c_lo + dc : c_hi + dc]
            if dr and dc:
                ok &= free[0 : ny - dr, c_lo + dc : c_hi + dc] & free[dr:ny, c_lo:c_hi]
            r, c = np.nonzero(ok)
            c = c + c_lo
            rows.append(node_of[r, c])
            cols.append(node_of[r + dr, c + dc])
            weights.append(np.full(len(r), res * math.hypot(dr, dc)))
        n = int(free.sum())
        graph = csr_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        )
        return graph, (x0, y0), free.shape

    def _xy(self, flat_cells: np.ndarray) -> np.ndarray:
        """Centres (K, 2) of grid cells given by flat index, m."""
        res = self.spec.resolution_m
        r, c = np.divmod(np.asarray(flat_cells, dtype=np.int64), self._shape[1])
        return np.column_stack(
            (self._origin[0] + (c + 0.5) * res, self._origin[1] + (r + 0.5) * res)
        )

    def _node_near(self, xy: Sequence[float]) -> int:
        """The graph node of the free cell nearest to ``xy`` (ties: the lowest index)."""
        if len(self._cells) == 0:
            raise ValueError("the world has no free space at this height and margin")
        d = np.hypot(*(self._node_xy - np.asarray(xy, dtype=float)[:2]).T)
        return int(np.argmin(d))

    def is_free(self, xy: Sequence[float]) -> bool:
        """Whether a point keeps the margin from every obstacle."""
        return bool(self._tolerant.covers(Point(float(xy[0]), float(xy[1]))))

    def segment_free(self, a: Sequence[float], b: Sequence[float]) -> bool:
        """Whether the straight segment a-b keeps the margin everywhere."""
        if np.allclose(a[:2], b[:2]):
            return self.is_free(a)
        return bool(self._tolerant.covers(LineString([tuple(a[:2]), tuple(b[:2])])))

    def path(self, start_xy: Sequence[float], goal_xy: Sequence[float]) -> np.ndarray:
        """Shortest clear path (M, 2) from start to goal, shortened by line of sight.

        Start and goal are joined to their nearest free cells; a start or goal inside the
        margin (a vehicle standing near a wall) is left straight towards the free space.

        Raises:
            ValueError: no path connects them.
        """
        key = (tuple(map(float, start_xy[:2])), tuple(map(float, goal_xy[:2])))
        if key not in self._paths:
            self._paths[key] = self._plan_path(start_xy, goal_xy)
        return self._paths[key].copy()

    def _plan_path(self, start_xy: Sequence[float], goal_xy: Sequence[float]) -> np.ndarray:
        a, b = self._node_near(start_xy), self._node_near(goal_xy)
        if a not in self._trees:
            _, pred = dijkstra(self._graph, directed=False, indices=a, return_predecessors=True)
            self._trees[a] = pred
        pred = self._trees[a]
        if a != b and pred[b] < 0:
            raise ValueError(f"no clear path from {tuple(start_xy[:2])} to {tuple(goal_xy[:2])}")
        nodes = [b]
        while nodes[-1] != a:
            nodes.append(int(pred[nodes[-1]]))
        cells = self._cells[np.array(nodes[::-1])]
        pts = np.vstack(
            [np.asarray(start_xy[:2], float), self._xy(cells), np.asarray(goal_xy[:2], float)]
        )
        return self._shortcut(pts)

    def _shortcut(self, pts: np.ndarray) -> np.ndarray:
        """Drop the points a straight clear segment can skip (greedy, farthest first)."""
        if len(pts) > 2:  # first the cells inside straight runs of the grid path
            a, b = pts[1:-1] - pts[:-2], pts[2:] - pts[1:-1]
            turn = np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]) > 1e-9
            pts = np.vstack([pts[:1], pts[1:-1][turn], pts[-1:]])
        out = [pts[0]]
        i, n = 0, len(pts)
        while i < n - 1:
            j = n - 1
            while j > i + 1 and not self.segment_free(pts[i], pts[j]):
                j -= 1
            out.append(pts[j])
            i = j
        keep = [out[0]]
        for p in out[1:]:
            if not np.allclose(p, keep[-1]):
                keep.append(p)
        return np.array(keep)

    # -- rooms ---------------------------------------------------------------------------------
    @cached_property
    def rooms(self) -> list[Room]:
        """The world's rooms with their goals (free, reachable points nearest their centres)."""
        out = []
        for k, outline in enumerate(find_rooms(self.world, self.spec.door_close_m)):
            inside = outline.intersection(self.free)
            if inside.is_empty:
                continue
            centre = outline.centroid
            goal = centre if inside.covers(centre) else nearest_points(inside, centre)[0]
            out.append(Room(k, outline, (float(goal.x), float(goal.y))))
        return out

    def distances(self, points_xy: Sequence[Sequence[float]]) -> np.ndarray:
        """Matrix (P, P) of clear path lengths between the points, m (symmetric)."""
        pts = [tuple(map(float, p[:2])) for p in points_xy]
        d = np.zeros((len(pts), len(pts)))
        for i, j in itertools.combinations(range(len(pts)), 2):
            d[i, j] = d[j, i] = polyline_length(self.path(pts[i], pts[j]))
        return d

    def split(self, reference_xy: Sequence[float], k: int) -> list[tuple[int, ...]]:
        """The rooms (indices into :attr:`rooms`) of each of ``k`` vehicles, in visiting order.

        Minimises the longest closed tour from ``reference_xy`` (then the total); exact up to
        :data:`EXACT_SPLIT_MAX_ROOMS` rooms. Vehicles beyond the number of rooms get none.
        """
        if k < 1:
            raise ValueError(f"k must be >= 1, got {k}")
        goals = [r.goal_xy_m for r in self.rooms]
        dist = self.distances([tuple(reference_xy[:2]), *goals])
        return [tuple(self.rooms[p].index for p in t) for t in split_tours(dist, k)]

    def route(self, start_xy: Sequence[float], rooms: Sequence[int]) -> Route:
        """The closed route from ``start_xy`` through the goals of ``rooms`` in that order."""
        by_index = {r.index: r for r in self.rooms}
        stops = (
            [tuple(start_xy[:2])] + [by_index[i].goal_xy_m for i in rooms] + [tuple(start_xy[:2])]
        )
        pieces = [np.asarray(stops[0], float).reshape(1, 2)]
        arrivals = []
        for a, b in itertools.pairwise(stops):
            leg = self.path(a, b)
            pieces.append(leg[1:])
            arrivals.append(sum(len(p) for p in pieces) - 1)
        return Route(tuple(rooms), np.vstack(pieces), tuple(arrivals[:-1]))


def tour_costs(dist: np.ndarray) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """Shortest closed tours from point 0 through every subset of points 1..n (Held-Karp).

    Returns each subset's (bit mask over points 1..n) tour length and its order (point indices,
    1-based).
    """
    n = len(dist) - 1
    full = 1 << n
    inf = math.inf
    best = np.full((full, n), inf)
    parent = np.full((full, n), -1, dtype=int)
    for j in range(n):
        best[1 << j, j] = dist[0, j + 1]
    for mask in range(1, full):
        for j in range(n):
            if not mask >> j & 1 or best[mask, j] == inf:
                continue
            for m in range(n):
                if mask >> m & 1:
                    continue
                nxt = mask | 1 << m
                cost = best[mask, j] + dist[j + 1, m + 1]
                if cost < best[nxt, m] - 1e-9:
                    best[nxt, m] = cost
                    parent[nxt, m] = j
    costs = np.zeros(full)
    orders: list[tuple[int, ...]] = [()] * full
    for mask in range(1, full):
        ends = best[mask] + dist[1:, 0]
        j = int(np.argmin(ends))
        costs[mask] = ends[j]
        order, m = [], mask
        while j >= 0:
            order.append(j + 1)
            j, m = int(parent[m, j]), m & ~(1 << j)
        orders[mask] = tuple(reversed(order))
    return costs, orders


def split_tours(dist: np.ndarray, k: int) -> list[tuple[int, ...]]:
    """Split points 1..n of ``dist`` into ``k`` closed tours from point 0.

    Returns each tour's points as 0-based indices into 1..n (i.e. point - 1), in visiting order;
    the tours are sorted by their first point so the result does not depend on ties.
    """
    n = len(dist) - 1
    if n == 0:
        return [() for _ in range(k)]
    if n > EXACT_SPLIT_MAX_ROOMS:
        return _split_greedy(dist, k)
    costs, orders = tour_costs(dist)
    full = (1 << n) - 1
    # best[c][mask]: (longest, total) over c tours covering mask; choice[c][mask]: last subset.
    best = [{0: (0.0, 0.0)}]
    choice: list[dict[int, int]] = [{}]
    for c in range(1, k + 1):
        level: dict[int, tuple[float, float]] = {}
        picks: dict[int, int] = {}
        for mask in range(full + 1):
            candidates = []
            sub = mask
            while True:
                rest = mask & ~sub
                if rest in best[c - 1]:
                    longest, total = best[c - 1][rest]
                    candidates.append(((max(longest, costs[sub]), total + costs[sub]), sub))
                if sub == 0:
                    break
                sub = (sub - 1) & mask
            if candidates:
                value, sub = min(
                    candidates, key=lambda t: (round(t[0][0], 6), round(t[0][1], 6), t[1])
                )
                level[mask], picks[mask] = value, sub
        best.append(level)
        choice.append(picks)
    tours, mask = [], full
    for c in range(k, 0, -1):
        sub = choice[c][mask]
        tours.append(tuple(p - 1 for p in orders[sub]) if sub else ())
        mask &= ~sub
    return sorted(tours, key=lambda t: (len(t) == 0, t[:1]))


def _split_greedy(dist: np.ndarray, k: int) -> list[tuple[int, ...]]:
    """Many rooms: one nearest-neighbour tour cut into ``k`` runs of nearly equal count."""
    n = len(dist) - 1
    left, order, here = set(range(1, n + 1)), [], 0
    while left:
        here = min(left, key=lambda j: (dist[here, j], j))
        order.append(here - 1)
        left.remove(here)
    bounds = np.linspace(0, n, k + 1).round().astype(int)
    return [tuple(order[bounds[i] : bounds[i + 1]]) for i in range(k)]


def truncate_rooms(
    planner: IndoorPlanner, start_xy: Sequence[float], rooms: Sequence[int], budget_m: float
) -> Route:
    """The route through the most of ``rooms`` whose closed route fits ``budget_m``.

    All of them in the given order when that fits; else, among the largest subsets whose
    shortest closed tour from ``start_xy`` fits, the shortest tour (exact up to
    :data:`EXACT_SPLIT_MAX_ROOMS` rooms, else the longest prefix that fits). A route visiting
    no room stays at the start.
    """
    full = planner.route(start_xy, rooms)
    if full.length_m <= budget_m or not rooms:
        return full
    if len(rooms) > EXACT_SPLIT_MAX_ROOMS:
        for count in range(len(rooms) - 1, -1, -1):
            route = planner.route(start_xy, rooms[:count])
            if route.length_m <= budget_m or count == 0:
                return route
    goals = {r.index: r.goal_xy_m for r in planner.rooms}
    dist = planner.distances([tuple(start_xy[:2]), *(goals[i] for i in rooms)])
    costs, orders = tour_costs(dist)
    fits = [m for m in range(1, len(costs)) if costs[m] <= budget_m]
    if not fits:
        return planner.route(start_xy, ())
    best = max(fits, key=lambda m: (bin(m).count("1"), -round(costs[m], 6), -m))
    return planner.route(start_xy, [rooms[p - 1] for p in orders[best]])
