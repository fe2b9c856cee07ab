"""Boustrophedon (zigzag) coverage of a polygon by K camera vehicles, in the world's ENU frame.

The free area (the area minus the obstacles grown by a margin) is swept by parallel lanes along
``sweep_deg`` (counter-clockwise from east), one camera footprint width apart less the overlap:
``spacing = 2 h tan(hfov / 2) (1 - overlap)`` for a down-looking camera at height ``h`` above the
surveyed plane z = 0 (Choset, "Coverage of known spaces: the boustrophedon cellular
decomposition", Autonomous Robots 9, 2000; lanes of one sensor width). The lanes are split into
K groups of neighbouring lanes with about equal total length: vehicle k sweeps the strip of the
free area that holds its group (the K strips run along the sweep direction and do not overlap).
Within its strip a vehicle flies its lanes in alternating directions, starting at the corner
nearest its start point; wherever a straight leg would cross an obstacle (a lane broken by it, or
the step to the next lane) it goes around along the shortest path of the free area's visibility
graph. A time budget truncates the path so that the vehicle can still fly back to its start.

Pure: shapely geometry and numpy in, numpy out; no I/O. Units: metres, seconds, degrees.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import networkx as nx
import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from companion.planning.coverage_partition import LATTICE_PARTITIONS, lattice_regions

_TOLERANCE_M = 1e-6
"""Slack of the "segment inside the free area" test (points on its boundary count as inside)."""

PARTITIONS = ("strips", *LATTICE_PARTITIONS)
"""Ways to share the free area among the vehicles (``CoverageSpec.partition``)."""


@dataclass(frozen=True)
class CoverageSpec:
    """How to cover: flight height, camera optics, lane overlap, sweep direction, margins."""

    altitude_m: float
    """Height of the camera above the surveyed plane z = 0, m (> 0); the waypoints' z."""
    hfov_deg: float
    """Horizontal field of view of the down-looking camera (across the track), degrees."""
    overlap: float = 0.2
    """Fraction of the footprint width neighbouring lanes share, in [0, 1)."""
    sweep_deg: float | None = None
    """Direction of the lanes, degrees counter-clockwise from east; None: along the longer
    side of the area's minimum rotated rectangle (fewest turns)."""
    margin_m: float = 10.0
    """Horizontal distance kept from every obstacle, m (>= 0)."""
    partition: str = "strips"
    """How the lanes are shared among the vehicles (one of ``PARTITIONS``): "strips", K strips
    of neighbouring lanes (``split``); otherwise regions of a lattice labelled by seed 004's
    partitioner of that name (``companion.planning.coverage_partition``)."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.altitude_m) and self.altitude_m > 0.0):
            raise ValueError(f"altitude_m must be positive, got {self.altitude_m!r}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if not 0.0 <= self.overlap < 1.0:
            raise ValueError(f"overlap must be in [0, 1), got {self.overlap!r}")
        if self.sweep_deg is not None and not math.isfinite(self.sweep_deg):
            raise ValueError(f"sweep_deg must be finite or None, got {self.sweep_deg!r}")
        if not (math.isfinite(self.margin_m) and self.margin_m >= 0.0):
            raise ValueError(f"margin_m must be >= 0, got {self.margin_m!r}")
        if self.partition not in PARTITIONS:
            raise ValueError(f"partition must be one of {PARTITIONS}, got {self.partition!r}")

    @property
    def footprint_width_m(self) -> float:
        """Width of the camera's footprint on the plane across the track, m."""
        return 2.0 * self.altitude_m * math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def lane_spacing_m(self) -> float:
        """Distance between neighbouring lanes, m."""
        return self.footprint_width_m * (1.0 - self.overlap)


@dataclass(frozen=True)
class Part:
    """One vehicle's share of the free area and its lanes (before ordering)."""

    polygon: BaseGeometry
    """The strip of the free area it covers (Polygon or MultiPolygon), ENU m."""
    lanes: tuple[tuple[LineString, ...], ...]
    """Its lanes, first to last across the strip; each a tuple of segments (a lane broken by
    obstacles has several) running along the sweep direction."""


@dataclass(frozen=True)
class VehiclePlan:
    """One vehicle's coverage path."""

    part: Part
    """What it was given to cover."""
    waypoints_enu_m: np.ndarray
    """(M, 3) waypoints, ENU m, z = ``CoverageSpec.altitude_m``; empty if the budget allows none."""
    length_m: float
    """Length of the path through the waypoints, m (without the legs from and to the start)."""
    transit_m: float
    """Straight distance from the start point to the first waypoint, m."""
    return_m: float
    """Straight distance from the last waypoint back to the start point, m (what the budget
    counts; the way around obstacles, ``return_route_enu_m``, may be a little longer)."""
    truncated: bool
    """True if the time budget cut the path short."""
    free_area: BaseGeometry | None = None
    """Where the vehicle may fly (the area minus the grown obstacles), for routing it later."""
    return_route_enu_m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    """(R, 3) corners leading around obstacles from the last waypoint back to the start
    (empty if the straight way is clear, or the start is in no free area), z as waypoints."""

    def flight_time_s(self, speed_m_s: float) -> float:
        """Time to fly start -> path -> start at ``speed_m_s``, s (no turns, no climbs)."""
        return (self.transit_m + self.length_m + self.return_m) / speed_m_s


def free_area(
    area: BaseGeometry, obstacles: Sequence[BaseGeometry], margin_m: float
) -> BaseGeometry:
    """``area`` minus the obstacles grown by ``margin_m`` (with few corners: cheap routing)."""
    if not obstacles:
        return area
    blocked = shapely.union_all([shapely.make_valid(o) for o in obstacles])
    if margin_m > 0.0:
        blocked = blocked.buffer(margin_m, quad_segs=2, join_style="mitre", mitre_limit=2.0)
    return shapely.make_valid(area.difference(blocked))


def sweep_direction_deg(area: BaseGeometry) -> float:
    """Direction of the longer side of ``area``'s minimum rotated rectangle, degrees in [0, 180)."""
    rect = shapely.minimum_rotated_rectangle(area)
    xy = np.asarray(rect.exterior.coords) if isinstance(rect, Polygon) else np.zeros((3, 2))
    sides = np.diff(xy[:3], axis=0)
    longer = sides[int(np.argmax(np.hypot(sides[:, 0], sides[:, 1])))]
    return math.degrees(math.atan2(longer[1], longer[0])) % 180.0


def _segments(geom: BaseGeometry) -> list[LineString]:
    """The non-degenerate line pieces of an intersection result, in order of their x."""
    parts = [g for g in getattr(geom, "geoms", [geom]) if isinstance(g, LineString)]
    lines = [g for g in parts if g.length > _TOLERANCE_M]
    return sorted(lines, key=lambda g: min(g.coords[0][0], g.coords[-1][0]))


def _lane_positions(y_min: float, y_max: float, spacing: float, at_least: int) -> np.ndarray:
    """Lane offsets across [y_min, y_max]: n lanes at most ``spacing`` apart, evenly, centred.

    n is the fewest lanes ``spacing`` apart that reach within half a spacing of both edges, or
    ``at_least`` if more; the lanes are then ``height / n`` apart with half that at the edges.
    """
    height = y_max - y_min
    n = max(at_least, math.ceil(height / spacing), 1)
    step = height / n
    return y_min + step / 2.0 + step * np.arange(n)


@functools.lru_cache(maxsize=8)
def split(free: BaseGeometry, spec: CoverageSpec, k: int) -> tuple[Part, ...]:
    """The free area's lanes shared among ``k`` vehicles as ``spec.partition`` says, one part each.

    "strips": ``k`` strips of neighbouring lanes of about equal lane length. Otherwise (and
    k >= 2) the regions of seed 004's partitioner of that name, each with the same lanes' pieces
    inside it (``coverage_partition.lattice_regions``); k = 1 is one part, the whole free area,
    whatever the partition. Deterministic: the same geometry, spec and ``k`` give the same parts
    on every vehicle, so each vehicle can plan its own part alone. Raises ``ValueError`` for an
    empty area, k < 1, or k the partition cannot share the lanes among. Remembered for the last
    few (geometry, spec, k): the vehicles of a swarm-scale run share one process and plan from
    the same inputs, so the split is made once, not once per vehicle.
    """
    if k < 1:
        raise ValueError(f"k (number of vehicles) must be >= 1, got {k}")
    if free.is_empty or free.area <= 0.0:
        raise ValueError("the area to cover is empty (obstacles and margins cover it all)")
    sweep = sweep_direction_deg(free) if spec.sweep_deg is None else spec.sweep_deg
    rotated = affinity.rotate(free, -sweep, origin=(0.0, 0.0))
    x_min, y_min, x_max, y_max = rotated.bounds

    def back(g: BaseGeometry) -> BaseGeometry:
        return affinity.rotate(g, sweep, origin=(0.0, 0.0))

    # Strips need k lanes at least; regions may share a lane, so they keep the spacing's lanes
    # (the same lanes as strips unless k exceeds their number), and a lattice of that size.
    lattice = spec.partition != "strips" and k > 1
    rows = [
        _segments(rotated.intersection(LineString([(x_min - 1, y), (x_max + 1, y)])))
        for y in _lane_positions(y_min, y_max, spec.lane_spacing_m, 1 if lattice else k)
    ]
    if lattice:
        regions = lattice_regions(
            rotated, rows, y_min, (y_max - y_min) / len(rows), k, spec.partition
        )
        return tuple(
            Part(polygon=back(g), lanes=tuple(tuple(back(s) for s in lane) for lane in own))
            for g, own in regions
        )
    lanes = [pieces for pieces in rows if pieces]
    if len(lanes) < k:
        raise ValueError(f"the area holds {len(lanes)} lanes, fewer than the {k} vehicles")
    lengths = np.array([sum(s.length for s in lane) for lane in lanes])
    cumulative = np.concatenate(([0.0], np.cumsum(lengths)))
    bounds = [0]
    for j in range(1, k):
        low, high = bounds[-1] + 1, len(lanes) - (k - j)
        candidates = np.arange(low, high + 1)
        target = cumulative[-1] * j / k
        bounds.append(int(candidates[np.argmin(np.abs(cumulative[candidates] - target))]))
    bounds.append(len(lanes))

    def lane_y(i: int) -> float:
        return lanes[i][0].coords[0][1]

    parts = []
    for j in range(k):
        first, last = bounds[j], bounds[j + 1] - 1
        low = y_min - 1.0 if j == 0 else (lane_y(first - 1) + lane_y(first)) / 2.0
        high = y_max + 1.0 if j == k - 1 else (lane_y(last) + lane_y(last + 1)) / 2.0
        strip = rotated.intersection(box(x_min - 1.0, low, x_max + 1.0, high))
        parts.append(
            Part(
                polygon=back(strip),
                lanes=tuple(tuple(back(s) for s in lanes[i]) for i in range(first, last + 1)),
            )
        )
    return tuple(parts)


class Router:
    """Shortest paths inside the free area (a visibility graph of its corners, built lazily)."""

    def __init__(self, free: BaseGeometry) -> None:
        self._tolerant = free.buffer(_TOLERANCE_M)
        shapely.prepare(self._tolerant)
        self._free = free
        self._graph: nx.Graph | None = None
        self._corners = np.zeros((0, 2))

    def contains(self, point: np.ndarray) -> bool:
        """Whether ``point`` (x, y) is in the free area."""
        return bool(shapely.covers(self._tolerant, Point(point[0], point[1])))

    def clear(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether the straight segment a-b stays in the free area."""
        return bool(shapely.covers(self._tolerant, LineString([a, b])))

    def _build(self) -> nx.Graph:
        rings = []
        for poly in getattr(self._free, "geoms", [self._free]):
            if isinstance(poly, Polygon) and not poly.is_empty:
                rings.extend([poly.exterior, *poly.interiors])
        self._corners = np.vstack([np.asarray(r.coords)[:-1, :2] for r in rings])
        xy = self._corners
        i, j = np.triu_indices(len(xy), k=1)
        ok = shapely.covers(self._tolerant, shapely.linestrings(np.stack([xy[i], xy[j]], axis=1)))
        graph = nx.Graph()
        graph.add_nodes_from(range(len(xy)))
        lengths = np.hypot(*(xy[j] - xy[i]).T)
        graph.add_weighted_edges_from(
            (int(a), int(b), float(w)) for a, b, w in zip(i[ok], j[ok], lengths[ok], strict=True)
        )
        return graph

    def path(self, a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
        """Corners to fly through from a to b (empty if the straight leg is clear)."""
        if self.clear(a, b):
            return []
        if self._graph is None:
            self._graph = self._build()
        graph = self._graph.copy()
        xy = self._corners
        for name, p in (("a", a), ("b", b)):
            lines = shapely.linestrings(np.stack([np.broadcast_to(p, xy.shape), xy], axis=1))
            seen = np.flatnonzero(shapely.covers(self._tolerant, lines))
            graph.add_weighted_edges_from(
                (name, int(c), float(np.hypot(*(xy[c] - p)))) for c in seen
            )
        try:
            nodes = nx.shortest_path(graph, "a", "b", weight="weight")
        except (nx.NetworkXNoPath, nx.NodeNotFound):
            return []  # no way around inside the area: fly straight (documented fallback)
        return [xy[n] for n in nodes[1:-1]]


def _ordered(part: Part, lane_order: int, first_dir: int) -> list[np.ndarray]:
    """The lane segments' end points in flight order for one of the four boustrophedon variants."""
    lanes = part.lanes if lane_order > 0 else part.lanes[::-1]
    points: list[np.ndarray] = []
    for n, lane in enumerate(lanes):
        forward = (n % 2 == 0) == (first_dir > 0)
        segments = lane if forward else lane[::-1]
        for seg in segments:
            xy = np.asarray(seg.coords)[:, :2]
            points.extend([xy[0], xy[-1]] if forward else [xy[-1], xy[0]])
    return points


def order_part(
    part: Part, free: BaseGeometry, start_xy_m: Sequence[float], router: Router | None = None
) -> np.ndarray:
    """A part's waypoints (M, 2), boustrophedon from the lane end nearest the start point.

    Legs between segments that would cross an obstacle go around it (corners of the free area).
    """
    start = np.asarray(start_xy_m, dtype=float)[:2]
    variants = [_ordered(part, o, d) for o in (1, -1) for d in (1, -1)]
    best = min(variants, key=lambda pts: float(np.hypot(*(pts[0] - start))))
    router = router or Router(free)
    out = [best[0]]
    for p in best[1:]:
        out.extend(router.path(out[-1], p))
        out.append(p)
    xy = np.asarray(out)
    keep = np.concatenate(([True], np.hypot(*np.diff(xy, axis=0).T) > _TOLERANCE_M))
    return xy[keep]


def path_length_m(xy: np.ndarray) -> float:
    """Length of the polyline through (M, 2+) points, m."""
    xy = np.asarray(xy, dtype=float)
    return float(np.hypot(*np.diff(xy[:, :2], axis=0).T).sum()) if len(xy) > 1 else 0.0


def truncate_to_budget(
    xy: np.ndarray, start_xy_m: Sequence[float], max_distance_m: float
) -> np.ndarray:
    """The longest beginning of the path such that start -> path -> start is <= max_distance_m.

    The legs from and to the start are straight (a return to launch flies straight). The last
    kept leg ends part way along where needed; an empty array if not even the first point fits.
    """
    xy = np.asarray(xy, dtype=float)[:, :2]
    start = np.asarray(start_xy_m, dtype=float)[:2]
    if len(xy) == 0:
        return xy

    def home(p: np.ndarray) -> float:
        return float(np.hypot(*(p - start)))

    flown = home(xy[0])
    if 2.0 * flown > max_distance_m:
        return xy[:0]
    out = [xy[0]]
    for a, b in itertools.pairwise(xy):
        leg = float(np.hypot(*(b - a)))
        if flown + leg + home(b) <= max_distance_m:
            out.append(b)
            flown += leg
            continue
        # flown + s + |a + s u - start| grows with s (triangle inequality): bisect for the end.
        low, high = 0.0, leg
        for _ in range(60):
            mid = (low + high) / 2.0
            if flown + mid + home(a + (b - a) * mid / leg) <= max_distance_m:
                low = mid
            else:
                high = mid
        if low > _TOLERANCE_M:
            out.append(a + (b - a) * low / leg)
        break
    return np.asarray(out)


def reachable_area(
    area: BaseGeometry,
    start_xy_m: Sequence[float],
    k: int,
    spec: CoverageSpec,
    max_distance_m: float,
) -> BaseGeometry:
    """``area`` cut to the square around the start that k vehicles can sweep in a flight each.

    Each vehicle flies ``max_distance_m`` = d (start, lanes and back). Its lanes cover about
    ``spacing * (d - s)`` m^2 when about s of d go to getting to its strip and back, so
    ``s^2 = k spacing (d - s)`` gives the square's side s (the positive root). ``area`` itself
    if the square would contain it.
    """
    if k < 1 or not max_distance_m > 0.0:
        raise ValueError(f"k must be >= 1 and max_distance_m > 0, got {k}, {max_distance_m}")
    w = k * spec.lane_spacing_m
    side = (-w + math.sqrt(w * w + 4.0 * w * max_distance_m)) / 2.0
    x, y = (float(v) for v in start_xy_m[:2])
    square = box(x - side / 2.0, y - side / 2.0, x + side / 2.0, y + side / 2.0)
    if square.contains(area):
        return area
    return shapely.make_valid(area.intersection(square))


def plan_vehicle(
    area: BaseGeometry,
    obstacles: Sequence[BaseGeometry],
    spec: CoverageSpec,
    k: int,
    index: int,
    start_xy_m: Sequence[float],
    speed_m_s: float | None = None,
    budget_s: float | None = None,
) -> VehiclePlan:
    """Vehicle ``index``'s (0-based) coverage path of its part of ``area`` among ``k`` vehicles.

    The path begins with the corners that lead around obstacles from the start to the first
    lane (if the start is in the free area), then sweeps the lanes.

    Args:
        area: the polygon to cover, ENU m.
        obstacles: footprints to keep ``spec.margin_m`` away from (solids, no-fly zones).
        spec: altitude, optics, overlap, sweep direction, margin.
        k: number of vehicles sharing the area.
        index: this vehicle's part, 0 <= index < k.
        start_xy_m: where the vehicle starts (and returns to), ENU m.
        speed_m_s: cruise speed, m/s (> 0), with ``budget_s``.
        budget_s: time for transit, path and return, s; None: no limit.
    """
    if not 0 <= index < k:
        raise ValueError(f"index must be in [0, {k}), got {index}")
    if budget_s is not None and not (speed_m_s is not None and speed_m_s > 0.0):
        raise ValueError(f"speed_m_s must be positive with a budget, got {speed_m_s!r}")
    if budget_s is not None and not budget_s >= 0.0:
        raise ValueError(f"budget_s must be >= 0, got {budget_s!r}")
    free = free_area(area, obstacles, spec.margin_m)
    part = split(free, spec, k)[index]
    router = Router(free)
    lanes = order_part(part, free, start_xy_m, router)
    # The way in from the start goes around obstacles too (the way back is the autopilot's).
    start = np.asarray(start_xy_m, dtype=float)[:2]
    start_free = bool(free.buffer(_TOLERANCE_M).covers(Point(start)))
    lead = router.path(start, lanes[0]) if start_free else []
    full = np.vstack([*lead, lanes]) if lead else lanes
    xy = full
    if budget_s is not None and speed_m_s is not None:
        xy = truncate_to_budget(full, start_xy_m, speed_m_s * budget_s)
    truncated = len(xy) < len(full) or (len(xy) > 0 and not np.allclose(xy[-1], full[-1]))
    waypoints = np.column_stack((xy, np.full(len(xy), spec.altitude_m))).reshape(-1, 3)
    back = np.asarray(router.path(xy[-1], start) if start_free and len(xy) else []).reshape(-1, 2)
    route = np.column_stack((back, np.full(len(back), spec.altitude_m))).reshape(-1, 3)
    return VehiclePlan(
        part=part,
        waypoints_enu_m=waypoints,
        length_m=path_length_m(xy),
        transit_m=float(np.hypot(*(xy[0] - start))) if len(xy) else 0.0,
        return_m=float(np.hypot(*(xy[-1] - start))) if len(xy) else 0.0,
        truncated=bool(truncated),
        free_area=free,
        return_route_enu_m=route,
    )


def plan_fleet(
    area: BaseGeometry,
    obstacles: Sequence[BaseGeometry],
    spec: CoverageSpec,
    starts_xy_m: Sequence[Sequence[float]],
    speed_m_s: float | None = None,
    budget_s: float | None = None,
) -> list[VehiclePlan]:
    """Every vehicle's plan (one per start point), as each vehicle computes its own."""
    k = len(starts_xy_m)
    return [
        plan_vehicle(area, obstacles, spec, k, i, s, speed_m_s, budget_s)
        for i, s in enumerate(starts_xy_m)
    ]
