"""Seed 004's whole plan: every free waypoint flown once, one task per vehicle, bad input named."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Polygon, box

from companion.planning.mco.auction import Bidder
from companion.planning.mco.plan import PLANNERS, McoParams, check_fleet_size, plan_mission
from companion.planning.mco.roles import Role
from companion.planning.mco.tours import straight_legs
from companion.planning.mco.workspace import Workspace

SMALL = {"gsd_m": 0.01}
"""A 40 m x 30 m footprint at 21 m: 10 m x 7.5 m cells, a few hundred waypoints here."""


def field() -> Workspace:
    """A 200 m x 150 m field with a no-fly hole and a zone of low interest."""
    hole = box(40.0, 90.0, 70.0, 120.0)
    polygon = Polygon(box(0.0, 0.0, 200.0, 150.0).exterior.coords, [hole.exterior.coords])
    return Workspace(polygon, (box(130.0, 20.0, 170.0, 60.0),))


def fleet(n: int) -> list[Bidder]:
    """Vehicle 3 is the only one able to be Master (decision and communication 3)."""
    out = []
    for v in range(1, n + 1):
        capable = v == 3
        out.append(Bidder(v, 600.0 + 10 * v, 3.0 if capable else 1.0, 3.0 if capable else 1.0))
    return out


@pytest.mark.parametrize("planner", PLANNERS)
def test_every_free_waypoint_is_flown_by_exactly_one_vehicle(planner: str) -> None:
    params = McoParams(planner=planner, fa_population=20, fa_iterations=50, **SMALL)
    n = 4 if planner != "boustrophedon" else 3
    home = np.array([100.0, 75.0])
    plan = plan_mission(field(), params, fleet(n), home, np.random.default_rng(1))
    flown = np.vstack([t.waypoints_xy_m for t in plan.tasks])
    assert sorted(map(tuple, flown)) == sorted(map(tuple, plan.grid.waypoints_xy_m))
    assert sorted(t.vehicle for t in plan.tasks) == list(range(1, n + 1))
    assert sorted(t.sub_area for t in plan.tasks) == list(range(n))
    assert sum(t.role == Role.MASTER for t in plan.tasks) == 1
    assert plan.task_of(3).role == Role.MASTER, "only vehicle 3 meets the Master's scores"
    for t in plan.tasks:
        # the tour leaves the take-off point and comes back: at least twice the farthest point
        far = np.max(np.hypot(*(t.waypoints_xy_m - home).T))
        assert t.path_length_m >= 2 * far - 1e-6
        assert t.flight_time_s > t.path_length_m / params.speed_m_s


def test_the_same_inputs_give_the_same_plan() -> None:
    params = McoParams(planner="mco_firefly", fa_population=20, fa_iterations=50, **SMALL)
    a, b = (
        plan_mission(field(), params, fleet(5), np.array([100.0, 75.0]), np.random.default_rng(7))
        for _ in range(2)
    )
    assert [t.sub_area for t in a.tasks] == [t.sub_area for t in b.tasks]
    for ta, tb in zip(a.tasks, b.tasks, strict=True):
        np.testing.assert_array_equal(ta.waypoints_xy_m, tb.waypoints_xy_m)


def test_firefly_tours_are_shorter_than_zigzag_on_the_same_partition() -> None:
    home = np.array([100.0, 75.0])
    lengths = {}
    for planner in ("mco_firefly", "mco_zigzag"):
        params = McoParams(planner=planner, fa_population=40, fa_iterations=300, **SMALL)
        plan = plan_mission(field(), params, fleet(3), home, np.random.default_rng(3))
        lengths[planner] = sum(t.path_length_m for t in plan.tasks)
    assert lengths["mco_firefly"] < lengths["mco_zigzag"]


def test_bad_fleet_sizes_and_cameras_are_errors_naming_the_value() -> None:
    ws = field()
    with pytest.raises(ValueError, match="n: 1 vehicles"):
        check_fleet_size(ws, McoParams(**SMALL), 1)
    with pytest.raises(ValueError, match="n: 5000 vehicles for"):
        check_fleet_size(ws, McoParams(**SMALL), 5000)
    with pytest.raises(ValueError, match="boustrophedon decomposition"):
        check_fleet_size(ws, McoParams(planner="boustrophedon", **SMALL), 10)
    with pytest.raises(ValueError, match="gsd_m"):
        McoParams(gsd_m=0.0)
    with pytest.raises(ValueError, match="planner"):
        McoParams(planner="spiral")
    with pytest.raises(ValueError, match="overlap"):
        McoParams(overlap=1.0)
    covered = Workspace(box(0.0, 0.0, 100.0, 100.0), (box(-1.0, -1.0, 101.0, 101.0),))
    with pytest.raises(ValueError, match="free"):
        check_fleet_size(covered, McoParams(**SMALL), 2)


def test_straight_legs_keep_the_corners_only() -> None:
    lane = np.array([[0, 0], [10, 0], [20, 0], [30, 0], [30, 10], [20, 10], [10, 10], [0, 10.0]])
    np.testing.assert_array_equal(straight_legs(lane), [[0, 0], [30, 0], [30, 10], [0, 10]])
    back = np.array([[0, 0], [10, 0], [5, 0.0]])  # a reversal is a corner
    np.testing.assert_array_equal(straight_legs(back), back)
    assert len(straight_legs(np.zeros((1, 2)))) == 1
