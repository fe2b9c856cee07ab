"""Zigzag coverage planning: lanes cover the free area, avoid obstacles, split it disjointly."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point, box

from companion.planning.coverage import (
    CoverageSpec,
    free_area,
    plan_fleet,
    plan_vehicle,
    reachable_area,
    split,
    truncate_to_budget,
)

AREA = box(-150.0, -100.0, 150.0, 100.0)
OBSTACLES = [
    box(-20.0, -10.0, 10.0, 25.0),  # a block in the middle
    Point(80.0, -40.0).buffer(12.0),  # a round tank
    shapely.Polygon([(-120, 60), (-90, 40), (-70, 80)]),  # a triangular no-fly zone
]
SPEC = CoverageSpec(altitude_m=20.0, hfov_deg=90.0, overlap=0.2, margin_m=5.0)
START = (-140.0, -95.0)


def _segments(waypoints: np.ndarray) -> list[LineString]:
    xy = waypoints[:, :2]
    return [LineString([a, b]) for a, b in itertools.pairwise(xy)]


def _covered(plans, spec: CoverageSpec):
    """Union of the camera footprints (width across the track) along every plan's path."""
    half = spec.footprint_width_m / 2.0
    return shapely.union_all(
        [LineString(p.waypoints_enu_m[:, :2]).buffer(half, cap_style="flat") for p in plans]
    )


@pytest.mark.parametrize("k", [1, 3])
def test_lanes_cover_the_free_area(k):
    """With no budget, the footprints along the K paths cover >= 95 % of the free area."""
    plans = plan_fleet(AREA, OBSTACLES, SPEC, [START] * k)
    free = free_area(AREA, OBSTACLES, SPEC.margin_m)
    fraction = _covered(plans, SPEC).intersection(free).area / free.area
    assert fraction >= 0.95
    # A wider camera needs fewer lanes, so a shorter path (the spacing follows the footprint).
    wide = CoverageSpec(altitude_m=20.0, hfov_deg=120.0, overlap=0.2, margin_m=5.0)
    assert sum(p.length_m for p in plan_fleet(AREA, OBSTACLES, wide, [START] * k)) < sum(
        p.length_m for p in plans
    )


def test_neighbouring_lanes_are_at_most_a_footprint_less_overlap_apart():
    """Lane spacing is 2 h tan(hfov / 2) (1 - overlap) or less: 20 m, 90 deg, 0.2 -> 32 m."""
    part = split(free_area(AREA, [], 0.0), SPEC, 1)[0]
    ys = [lane[0].coords[0][1] for lane in part.lanes]  # lanes run east-west, the longer side
    assert all(lane[0].coords[0][1] == lane[0].coords[-1][1] for lane in part.lanes)
    gaps = np.diff(sorted(ys))
    assert gaps.max() <= 2 * 20.0 * math.tan(math.radians(45.0)) * 0.8 + 1e-9
    assert len(ys) == math.ceil(200.0 / 32.0)


@pytest.mark.parametrize("k", [1, 2, 3])
@pytest.mark.parametrize("start", [START, (-5.0, 35.0), (100.0, -40.0)])
def test_no_leg_crosses_an_obstacle(k, start):
    """Every leg, from the start through the waypoints and back, keeps the margin from every
    obstacle (detours; starts behind the block and the tank need one to and from their lanes)."""
    for plan in plan_fleet(AREA, OBSTACLES, SPEC, [start] * k):
        assert len(plan.waypoints_enu_m) >= 2
        home = [[*start, SPEC.altitude_m]]
        legs = np.vstack([home, plan.waypoints_enu_m, plan.return_route_enu_m, home])
        for seg in _segments(legs):
            for obstacle in OBSTACLES:
                assert seg.distance(obstacle) >= SPEC.margin_m - 1e-3


def test_a_lane_broken_by_an_obstacle_goes_around_it():
    """An obstacle across the only lane: the path goes around it to the lane's far end."""
    strip = box(0.0, -10.0, 200.0, 10.0)
    wall = box(90.0, -30.0, 110.0, 5.0)  # leaves a gap at the north side
    spec = CoverageSpec(altitude_m=10.0, hfov_deg=100.0, overlap=0.0, margin_m=2.0)  # 1 lane
    plan = plan_vehicle(strip, [wall], spec, 1, 0, (0.0, 0.0))
    for seg in _segments(plan.waypoints_enu_m):
        assert seg.distance(wall) >= 2.0 - 1e-3
    assert plan.waypoints_enu_m[0, 0] == pytest.approx(0.0)
    assert plan.waypoints_enu_m[-1, 0] == pytest.approx(200.0)
    assert plan.length_m > 200.0 - 2 * 2.0


def test_parts_are_disjoint_and_make_up_the_free_area():
    """K strips do not overlap; together they are the whole free area; lanes stay in their part."""
    free = free_area(AREA, OBSTACLES, SPEC.margin_m)
    parts = split(free, SPEC, 3)
    for i in range(3):
        for j in range(i + 1, 3):
            assert parts[i].polygon.intersection(parts[j].polygon).area < 1e-6
    assert shapely.union_all([p.polygon for p in parts]).area == pytest.approx(free.area)
    for part in parts:
        for lane in part.lanes:
            for seg in lane:
                assert part.polygon.buffer(1e-6).covers(seg)
    lengths = [sum(s.length for lane in p.lanes for s in lane) for p in parts]
    assert max(lengths) < 1.6 * min(lengths)  # about equal shares of lane length


def test_plans_are_deterministic_and_start_near_the_start_point():
    """The same input gives the same waypoints; the path begins at the lane end nearest START."""
    a = plan_vehicle(AREA, OBSTACLES, SPEC, 3, 1, START)
    b = plan_vehicle(AREA, OBSTACLES, SPEC, 3, 1, START)
    np.testing.assert_array_equal(a.waypoints_enu_m, b.waypoints_enu_m)
    ends = [
        np.asarray(c) for lane in a.part.lanes for s in lane for c in (s.coords[0], s.coords[-1])
    ]
    nearest = min(float(np.hypot(*(e - START))) for e in ends)
    assert a.transit_m == pytest.approx(nearest)
    assert np.all(a.waypoints_enu_m[:, 2] == SPEC.altitude_m)


def test_a_time_budget_truncates_the_path_to_fly_it_and_return():
    """start -> path -> start at speed v fits the budget; the cut path begins as the full one."""
    full = plan_vehicle(AREA, OBSTACLES, SPEC, 2, 0, START)
    speed, budget = 5.0, 0.4 * full.flight_time_s(5.0)
    cut = plan_vehicle(AREA, OBSTACLES, SPEC, 2, 0, START, speed, budget)
    assert cut.truncated and not full.truncated
    assert cut.flight_time_s(speed) == pytest.approx(budget, rel=1e-6)
    n = len(cut.waypoints_enu_m)
    np.testing.assert_allclose(cut.waypoints_enu_m[: n - 1], full.waypoints_enu_m[: n - 1])
    end = LineString(full.waypoints_enu_m[n - 2 : n, :2])
    assert end.distance(Point(cut.waypoints_enu_m[-1, :2])) < 1e-6
    # Not even the first waypoint and back fits: nothing to fly.
    assert len(truncate_to_budget(full.waypoints_enu_m, (1000.0, 0.0), 100.0)) == 0


def test_bad_input_names_the_field():
    """Wrong parameters raise ValueError naming the field."""
    with pytest.raises(ValueError, match="overlap"):
        CoverageSpec(altitude_m=10.0, hfov_deg=90.0, overlap=1.0)
    with pytest.raises(ValueError, match="altitude_m"):
        CoverageSpec(altitude_m=0.0, hfov_deg=90.0)
    with pytest.raises(ValueError, match="hfov_deg"):
        CoverageSpec(altitude_m=10.0, hfov_deg=180.0)
    with pytest.raises(ValueError, match="index"):
        plan_vehicle(AREA, [], SPEC, 2, 2, START)
    with pytest.raises(ValueError, match="empty"):
        plan_vehicle(box(0, 0, 5, 5), [box(-1, -1, 6, 6)], SPEC, 1, 0, START)
    with pytest.raises(ValueError, match="speed_m_s"):
        plan_vehicle(AREA, [], SPEC, 1, 0, START, None, 10.0)


def test_the_reachable_area_is_what_the_fleet_can_sweep_in_its_distance():
    """Cut to a square around the start whose lanes, shared by k, fit the distance about."""
    big = box(-1000.0, -1000.0, 1000.0, 1000.0)
    reach = reachable_area(big, (100.0, 50.0), 3, SPEC, 600.0)
    side = math.sqrt(reach.area)
    assert reach.centroid.x == pytest.approx(100.0) and reach.centroid.y == pytest.approx(50.0)
    # k vehicles' lanes (area / spacing) plus about one side of getting there and back each.
    assert side * side / SPEC.lane_spacing_m + 3 * side == pytest.approx(3 * 600.0)
    plans = plan_fleet(reach, [], SPEC, [(100.0, 50.0)] * 3, speed_m_s=1.0, budget_s=600.0)
    assert all(len(p.waypoints_enu_m) >= 2 for p in plans)
    assert reachable_area(AREA, (0.0, 0.0), 3, SPEC, 1e6) is AREA  # all of it is in reach
