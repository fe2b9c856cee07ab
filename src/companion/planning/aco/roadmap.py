"""The random-point roadmap ACO walks on (seed 001, Alg. 1 lines 3-4): a seeded PRM-like graph.

Seed 001 builds "a list of random points representing the map, including start and target
nodes" and "connects nodes with edges" (Alg. 1, lines 3-4); it gives neither the number of points,
the edge rule, nor whether points are 3-D (digest 004_001 §6 item 1). Choices here:

* **3-D box.** Nodes are uniform in an axis-aligned ENU box; the default is the arena of
  ``worlds.arenas.build_arena_aco`` (1 km x 1 km, Sec. 4.1, centred on the origin) and the
  altitude band of its moving obstacles, 10-60 m (the paper gives no altitude bound). A 2-D
  roadmap is the same box with ``z_min_m == z_max_m``.
* **Nodes.** :attr:`RoadmapParams.nodes` = 200 random points (plus the start, node 0, and the
  target, node 1): at 1 km x 1 km one point per ~70 m x 70 m, ~15 hops across the arena. Larger
  roadmaps do not pay here: with k fixed their shortest paths zigzag more (A*/straight 1.06 at
  200 nodes, 1.08 at 500, 1.11 at 2000), the colony's 50 iterations find them less well (ACO/A*
  1.02 at 200 nodes, 1.06 at 500, 1.16 at 1000, 20 ants) and cost more (2.3 ms per colony at
  200, 10 ms at 500, 21 ms at 1000); 80 plans at 200 nodes, roadmap built per UAV, take ~0.5 s
  of Eq. 11's 0.833 s on one loaded core (``benchmarks/aco_plan.py``).
* **Edges.** Symmetrised k-nearest neighbours (``scipy.spatial.cKDTree``; an edge i-j when j is
  among i's k nearest or i among j's), k = :attr:`RoadmapParams.neighbours` = 10, so every node has
  degree >= k and the graph does not fall apart in sparse corners as a fixed radius would.
* **Obstacles: off by default.** The paper's ACO most likely does not see obstacles (avoidance
  is reactive, Sec. 3.2; digest §6 item 1), so :func:`build_roadmap` ignores them unless
  ``solids`` is given. Given :class:`Prism` solids (a shapely footprint standing on the ground up
  to ``height_m``: boxes, yawed boxes, vertical cylinders), nodes inside a solid are dropped and
  edges whose segment passes through one are removed. ``worlds.model.Solid`` is not imported
  (``companion`` sees map data only): an adapter passes ``Prism(s.footprint_at(t), z_top)``.
* **Unreachable target.** If no path joins the start and the target (obstacles cut the graph, a
  start inside a solid), :func:`build_roadmap` raises ``ValueError`` naming both.

Deterministic for a seed: the points come from the ``numpy.random.Generator`` passed in, the
neighbour lists from a k-d tree queried in node order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree
from shapely.geometry import Polygon

START = 0
"""Node index of the start in every roadmap."""
TARGET = 1
"""Node index of the target in every roadmap."""


@dataclass(frozen=True)
class RoadmapParams:
    """Where and how densely :func:`build_roadmap` samples (choices: seed 001 gives none)."""

    nodes: int = 200
    """Random points besides the start and the target."""
    neighbours: int = 10
    """k of the symmetrised k-nearest-neighbour edge rule."""
    min_enu_m: tuple[float, float, float] = (-500.0, -500.0, 10.0)
    """Lower corner of the sampling box, ENU, m (the 1 km arena, 10 m above ground)."""
    max_enu_m: tuple[float, float, float] = (500.0, 500.0, 60.0)
    """Upper corner of the sampling box, ENU, m (equal z corners: a 2-D roadmap)."""

    def __post_init__(self) -> None:
        if self.nodes < 0:
            raise ValueError(f"nodes must be >= 0, got {self.nodes}")
        if self.neighbours < 1:
            raise ValueError(f"neighbours must be >= 1, got {self.neighbours}")
        lo, hi = np.asarray(self.min_enu_m, float), np.asarray(self.max_enu_m, float)
        if lo.shape != (3,) or hi.shape != (3,) or not np.isfinite([*lo, *hi]).all():
            raise ValueError(f"min_enu_m, max_enu_m must be finite 3-vectors: {lo}, {hi}")
        if (hi < lo).any():
            raise ValueError(f"max_enu_m {self.max_enu_m} must be >= min_enu_m {self.min_enu_m}")


@dataclass(frozen=True)
class Prism:
    """A static solid seen by the roadmap: a footprint standing on the ground, up to a height."""

    footprint: Polygon
    """Outline seen from above, ENU x/y, m."""
    height_m: float
    """Top of the solid above z = 0, m."""

    def __post_init__(self) -> None:
        if not math.isfinite(self.height_m) or self.height_m <= 0.0:
            raise ValueError(f"Prism.height_m must be finite and > 0, got {self.height_m}")


@dataclass(frozen=True)
class Roadmap:
    """An undirected graph in CSR form: node 0 is the start, node 1 the target."""

    points_enu_m: np.ndarray
    """``(n, 3)`` node positions, ENU, m."""
    indptr: np.ndarray
    """``(n + 1,)`` int64: node i's neighbours are ``indices[indptr[i]:indptr[i + 1]]``."""
    indices: np.ndarray
    """``(2E,)`` int64 neighbour of each directed slot (each edge appears once per direction)."""
    edge_id: np.ndarray
    """``(2E,)`` int64 undirected edge of each slot, in ``[0, E)`` (one pheromone per edge)."""
    length_m: np.ndarray
    """``(2E,)`` float64 Euclidean length of each slot's edge, m."""

    @property
    def n_nodes(self) -> int:
        """Nodes, the start and the target included."""
        return len(self.points_enu_m)

    @property
    def n_edges(self) -> int:
        """Undirected edges."""
        return len(self.indices) // 2

    def path_length_m(self, path: np.ndarray) -> float:
        """Length of a node sequence along straight edges, m."""
        p = self.points_enu_m[np.asarray(path, dtype=np.int64)]
        return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def build_roadmap(
    start_enu_m: np.ndarray,
    target_enu_m: np.ndarray,
    params: RoadmapParams,
    rng: np.random.Generator,
    solids: tuple[Prism, ...] = (),
) -> Roadmap:
    """The roadmap of Alg. 1 lines 3-4 between ``start`` (node 0) and ``target`` (node 1).

    Raises ``ValueError`` when the target cannot be reached from the start on the graph.
    """
    start = _point(start_enu_m, "start_enu_m")
    target = _point(target_enu_m, "target_enu_m")
    lo, hi = np.asarray(params.min_enu_m, float), np.asarray(params.max_enu_m, float)
    points = np.vstack([start, target, lo + (hi - lo) * rng.random((params.nodes, 3))])
    if solids:
        keep = ~_inside(points[2:], solids)
        points = np.vstack([points[:2], points[2:][keep]])
    n = len(points)
    k = min(params.neighbours, n - 1)
    if k < 1:
        raise ValueError(
            f"target {tuple(target)} is unreachable from start {tuple(start)}: no other node"
        )
    _, near = cKDTree(points).query(points, k=k + 1)
    rows = np.repeat(np.arange(n), k)
    cols = near[:, 1:].reshape(-1)
    i, j = np.minimum(rows, cols), np.maximum(rows, cols)
    key = np.unique((i * n + j)[i != j])  # one int per edge: faster than unique rows
    pairs = np.column_stack([key // n, key % n])
    if solids:
        pairs = pairs[~_blocked(points, pairs, solids)]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    if label[START] != label[TARGET]:
        raise ValueError(
            f"target {tuple(target.tolist())} is unreachable from start {tuple(start.tolist())} "
            f"on the roadmap ({n} nodes, {len(pairs)} edges, {len(solids)} solids)"
        )
    return roadmap_from_edges(points, pairs)


def _point(value: np.ndarray, name: str) -> np.ndarray:
    """A finite ENU 3-vector or ``ValueError``."""
    p = np.asarray(value, dtype=float)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"{name} must be a finite (3,) ENU point, m, got {value!r}")
    return p


def _inside(points: np.ndarray, solids: tuple[Prism, ...]) -> np.ndarray:
    """Which points lie in (or on) a solid."""
    inside = np.zeros(len(points), dtype=bool)
    xy = shapely.points(points[:, :2])
    for s in solids:
        inside |= shapely.intersects(s.footprint, xy) & (points[:, 2] <= s.height_m)
    return inside


def _blocked(points: np.ndarray, pairs: np.ndarray, solids: tuple[Prism, ...]) -> np.ndarray:
    """Which edges pass through a solid.

    The segment's height is linear along it, so its lowest point over the part above a footprint
    is at an end of one of the intersection's pieces: the edge is blocked if that is below the top.
    """
    a, b = points[pairs[:, 0]], points[pairs[:, 1]]
    lines = shapely.linestrings(np.stack([a[:, :2], b[:, :2]], axis=1))
    tree = shapely.STRtree(lines)
    blocked = np.zeros(len(pairs), dtype=bool)
    for s in solids:
        for e in tree.query(s.footprint, predicate="intersects"):
            if blocked[e]:
                continue
            cut = np.asarray(shapely.get_coordinates(s.footprint.intersection(lines[e])))
            d = b[e, :2] - a[e, :2]
            span = float(d @ d)
            t = np.clip((cut - a[e, :2]) @ d / span, 0.0, 1.0) if span > 0.0 else np.zeros(1)
            blocked[e] = (a[e, 2] + t * (b[e, 2] - a[e, 2])).min() <= s.height_m
    return blocked


def roadmap_from_edges(points: np.ndarray, pairs: np.ndarray) -> Roadmap:
    """The :class:`Roadmap` of ``(n, 3)`` points and ``(E, 2)`` undirected edges (i < j, unique).

    Node 0 must be the start and node 1 the target. For hand-built graphs and map exports.
    """
    points = np.asarray(points, dtype=np.float64)
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    m = len(pairs)
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    eid = np.concatenate([np.arange(m), np.arange(m)])
    order = np.lexsort((dst, src))
    src, dst, eid = src[order], dst[order], eid[order]
    indptr = np.zeros(len(points) + 1, dtype=np.int64)
    np.cumsum(np.bincount(src, minlength=len(points)), out=indptr[1:])
    length = np.linalg.norm(points[dst] - points[src], axis=1)
    return Roadmap(
        np.ascontiguousarray(points, dtype=np.float64),
        indptr,
        np.ascontiguousarray(dst, dtype=np.int64),
        np.ascontiguousarray(eid, dtype=np.int64),
        np.ascontiguousarray(length, dtype=np.float64),
    )
