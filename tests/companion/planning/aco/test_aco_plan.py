"""plan_path: the facade from a start and a target to ENU waypoints."""

from __future__ import annotations

import numpy as np
import pytest

from companion.planning.aco.plan import PlannedPath, Planner, plan_path, straight_line_length
from companion.planning.aco.roadmap import RoadmapParams, build_roadmap

A = np.array([-400.0, 0.0, 20.0])
B = np.array([400.0, 50.0, 40.0])


@pytest.mark.parametrize("planner", ["aco", "astar", Planner.ACO])
def test_waypoints_run_from_start_to_target(planner):
    """First and last waypoints are the end points; the length is the polyline's; not shorter
    than the straight line; A* no longer than ACO on the same roadmap."""
    plan = plan_path(A, B, RoadmapParams(), np.random.default_rng(1), planner)
    assert isinstance(plan, PlannedPath)
    w = plan.waypoints_enu_m
    assert w.shape[1] == 3 and len(w) >= 2
    np.testing.assert_array_equal(w[0], A)
    np.testing.assert_array_equal(w[-1], B)
    assert plan.length_m == pytest.approx(np.linalg.norm(np.diff(w, axis=0), axis=1).sum())
    assert plan.length_m >= straight_line_length(A, B)
    assert plan.plan_ms > 0.0
    optimum = plan_path(A, B, RoadmapParams(), np.random.default_rng(1), "astar")
    assert optimum.length_m <= plan.length_m + 1e-9


def test_given_roadmap_is_used_and_checked():
    """A prebuilt roadmap's nodes are the waypoints; end points it was not built for raise."""
    rm = build_roadmap(A, B, RoadmapParams(), np.random.default_rng(2))
    plan = plan_path(A, B, rm, np.random.default_rng(3), "astar")
    assert all((rm.points_enu_m == w).all(axis=1).any() for w in plan.waypoints_enu_m)
    with pytest.raises(ValueError, match="roadmap was built for start"):
        plan_path(A + 1.0, B, rm, np.random.default_rng(3))


def test_unknown_planner_rejected():
    with pytest.raises(ValueError, match="dijkstra"):
        plan_path(A, B, RoadmapParams(), np.random.default_rng(0), "dijkstra")


def test_straight_line_length():
    assert straight_line_length(np.zeros(3), np.array([3.0, 4.0, 12.0])) == pytest.approx(13.0)
