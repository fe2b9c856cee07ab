"""One call from a start and a target to waypoints: seed 001's ACO plan or the A* baseline.

The facade the swarm and MAVSDK adapters call (Alg. 3: each UAV plans its own path before the
main loop). It builds the roadmap (:mod:`companion.planning.aco.roadmap`) unless one is given,
runs the planner, and returns the nodes' positions as ENU waypoints with the path length and the
planning wall time (seed 001's real-time bound, Eqs. 11-12, is on that time).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from companion.planning.aco.astar import astar_path
from companion.planning.aco.colony import AcoParams, aco_path
from companion.planning.aco.roadmap import (
    START,
    TARGET,
    Prism,
    Roadmap,
    RoadmapParams,
    build_roadmap,
)


class Planner(StrEnum):
    """Which planner :func:`plan_path` runs."""

    ACO = "aco"
    """Seed 001's Ant System (:func:`~companion.planning.aco.colony.aco_path`)."""
    ASTAR = "astar"
    """The shortest path on the same roadmap (:func:`~companion.planning.aco.astar.astar_path`)."""


@dataclass(frozen=True)
class PlannedPath:
    """A planned path: waypoints from the start to the target."""

    waypoints_enu_m: np.ndarray
    """``(K, 3)`` roadmap nodes from the start to the target, ENU, m (both ends included)."""
    length_m: float
    """Length along the waypoints, m."""
    plan_ms: float
    """Wall time of the plan, roadmap construction included, ms."""


def plan_path(
    start_enu_m: np.ndarray,
    target_enu_m: np.ndarray,
    roadmap: Roadmap | RoadmapParams,
    rng: np.random.Generator,
    planner: Planner | str = Planner.ACO,
    aco: AcoParams = AcoParams(),  # noqa: B008 (frozen)
    solids: tuple[Prism, ...] = (),
) -> PlannedPath:
    """Plan ``start -> target`` on ``roadmap`` (or on one built from ``RoadmapParams``).

    A given :class:`Roadmap` must have ``start`` as node 0 and ``target`` as node 1 (``solids``
    are then ignored: they were used when it was built). Raises ``ValueError`` on an unreachable
    target, a roadmap built for other end points, or an unknown planner.
    """
    t0 = time.perf_counter()
    kind = Planner(planner)
    if isinstance(roadmap, RoadmapParams):
        roadmap = build_roadmap(start_enu_m, target_enu_m, roadmap, rng, solids)
    else:
        ends = np.stack([np.asarray(start_enu_m, float), np.asarray(target_enu_m, float)])
        if ends.shape != (2, 3) or not np.allclose(ends, roadmap.points_enu_m[[START, TARGET]]):
            raise ValueError(
                f"roadmap was built for start {roadmap.points_enu_m[START].tolist()} and target "
                f"{roadmap.points_enu_m[TARGET].tolist()}, not {ends.tolist()}"
            )
    if kind is Planner.ACO:
        path = aco_path(roadmap, aco, rng).path
    else:
        path, _ = astar_path(roadmap)
    waypoints = roadmap.points_enu_m[path]
    return PlannedPath(waypoints, roadmap.path_length_m(path), (time.perf_counter() - t0) * 1e3)


def straight_line_length(start_enu_m: np.ndarray, target_enu_m: np.ndarray) -> float:
    """Straight distance start -> target, m (seed 001's "minimum distance" of Eq. 4)."""
    return float(np.linalg.norm(np.asarray(target_enu_m, float) - np.asarray(start_enu_m, float)))
