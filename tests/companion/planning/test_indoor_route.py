"""Indoor room routes: rooms found, paths clear of solids by the margin, rooms split, repeatable."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Point

import worlds
from companion.planning.indoor_route import (
    IndoorPlanner,
    RouteSpec,
    blocking_footprints,
    find_rooms,
    split_tours,
    truncate_rooms,
)
from worlds.examples import example_path
from worlds.model import LaunchArea, Solid, Surface, World
from worlds.shapes import centred_rectangle

SPEC = RouteSpec(altitude_m=1.5, margin_m=0.55, resolution_m=0.25)


@pytest.fixture(scope="module")
def plant() -> World:
    return worlds.build(worlds.load_world(example_path("indoor")))


@pytest.fixture(scope="module")
def planner(plant: World) -> IndoorPlanner:
    return IndoorPlanner(plant, SPEC)


def _safe_point(world: World) -> tuple[float, float]:
    c = world.launch_area("safe_point").center_enu_m
    return (float(c[0]), float(c[1]))


def _clearance(world: World, points: np.ndarray, spec: RouteSpec) -> float:
    """Least distance of the polyline from the solids that block at the flight height, m."""
    blocked = shapely.union_all(blocking_footprints(world, spec.altitude_m, spec.margin_m))
    return float(LineString(points).distance(blocked))


def two_rooms() -> World:
    """A 20 x 10 m hall split by a wall with a 1.5 m doorway at x = 0, y = 3 (and a pipe)."""
    wall = (0.8, 0.8, 0.8, 1.0)
    solids = [
        Solid("wall", "box", (0.0, -10.0, 3.0), (20.3, 0.3, 6.0), 0.0, wall),  # south
        Solid("wall", "box", (0.0, 0.0, 3.0), (20.3, 0.3, 6.0), 0.0, wall),  # north
        Solid("wall", "box", (-10.0, -5.0, 3.0), (0.3, 10.0, 6.0), 0.0, wall),
        Solid("wall", "box", (10.0, -5.0, 3.0), (0.3, 10.0, 6.0), 0.0, wall),
        # the middle wall, x = 0, from y = -10 to -2.75 and -1.25 to 0: doorway at y = -2
        Solid("wall", "box", (0.0, -6.375, 3.0), (0.3, 7.25, 6.0), 0.0, wall),
        Solid("wall", "box", (0.0, -0.625, 3.0), (0.3, 1.25, 6.0), 0.0, wall),
        Solid("pipe", "box", (0.0, -5.0, 4.5), (20.0, 0.3, 0.3), 0.0, wall),  # overhead
    ]
    return World(
        kind="indoor",
        seed=0,
        size_m=(24.0, 24.0),
        boundary=centred_rectangle(24.0, 24.0),
        surface=Surface("floor", (0.5, 0.5, 0.5, 1.0), "concrete", 1.0, 0.1),
        solids=tuple(solids),
        launch_areas=(LaunchArea("start", (-5.0, -5.0, 0.0), 1.0),),
        gps_denied=True,
    )


def test_rooms_of_the_plant_are_its_six_rooms(plant: World, planner: IndoorPlanner) -> None:
    outlines = find_rooms(plant)
    assert len(outlines) == 6
    centres = sorted((round(o.centroid.x), round(o.centroid.y)) for o in outlines)
    assert centres == sorted((x, y) for x in (-20, 0, 20) for y in (-10, 10))
    for room in planner.rooms:
        goal = Point(room.goal_xy_m)
        assert room.outline.contains(goal)
        assert planner.is_free(room.goal_xy_m)
        # the goal is the room's centre unless machinery stands there
        assert goal.distance(room.outline.centroid) < 3.0


def test_path_goes_through_the_doorway_and_keeps_the_margin() -> None:
    world = two_rooms()
    planner = IndoorPlanner(world, SPEC)
    path = planner.path((-5.0, -5.0), (5.0, -5.0))
    line = LineString(path)
    assert _clearance(world, path, SPEC) >= SPEC.margin_m - 1e-6
    crossing = line.intersection(LineString([(0.0, -10.0), (0.0, 0.0)]))
    assert abs(crossing.y - (-2.0)) <= 0.75 - SPEC.margin_m + 1e-6  # within the doorway's middle
    # the overhead pipe (bottom 4.35 m) does not block at 1.5 m, but does at 4.4 m
    assert planner.is_free((5.0, -5.0))
    high = IndoorPlanner(world, RouteSpec(altitude_m=4.4, margin_m=0.55))
    assert not high.is_free((5.0, -5.0))


def test_no_path_through_a_doorway_narrower_than_twice_the_margin() -> None:
    planner = IndoorPlanner(two_rooms(), RouteSpec(margin_m=0.8))
    with pytest.raises(ValueError, match="no clear path"):
        planner.path((-5.0, -5.0), (5.0, -5.0))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_split_gives_every_room_to_one_vehicle_and_routes_reach_them(
    plant: World, planner: IndoorPlanner, k: int
) -> None:
    start = _safe_point(plant)
    parts = planner.split(start, k)
    assert len(parts) == k
    flat = [r for part in parts for r in part]
    assert sorted(flat) == [r.index for r in planner.rooms]
    goals = {r.index: r.goal_xy_m for r in planner.rooms}
    lengths = []
    for part in parts:
        route = planner.route(start, part)
        pts = route.waypoints_xy_m
        np.testing.assert_allclose(pts[0], start)
        np.testing.assert_allclose(pts[-1], start)
        for room, at in zip(part, route.room_waypoint, strict=True):
            np.testing.assert_allclose(pts[at], goals[room], atol=1e-9)
        # leaving the launch point (in the yard, clear) the route keeps the margin everywhere
        assert _clearance(plant, pts, SPEC) >= SPEC.margin_m - 1e-6
        lengths.append(route.length_m)
    if k == 2:  # balanced: the longer tour is not much longer than the shorter
        assert max(lengths) < 1.5 * min(lengths)


def test_planning_is_deterministic(plant: World, planner: IndoorPlanner) -> None:
    again = IndoorPlanner(plant, SPEC)
    start = _safe_point(plant)
    assert again.split(start, 2) == planner.split(start, 2)
    for part in planner.split(start, 2):
        np.testing.assert_array_equal(
            again.route(start, part).waypoints_xy_m, planner.route(start, part).waypoints_xy_m
        )


def test_split_tours_is_optimal_on_points_on_a_line() -> None:
    # depot at 0, points at -3, -1, 2, 5 on a line: the best 2-split is {-3, -1} and {2, 5}
    xs = np.array([0.0, -3.0, -1.0, 2.0, 5.0])
    dist = np.abs(xs[:, None] - xs[None, :])
    parts = split_tours(dist, 2)
    assert sorted(tuple(sorted(p)) for p in parts) == [(0, 1), (2, 3)]

    # brute force: no other split has a shorter longest tour (tour = 2 x farthest point)
    def longest(split: list[tuple[int, ...]]) -> float:
        return max((2 * max(abs(xs[i + 1]) for i in p) if p else 0.0) for p in split)

    best = min(
        longest(
            [tuple(i for i in range(4) if m >> i & 1), tuple(i for i in range(4) if not m >> i & 1)]
        )
        for m in range(16)
    )
    assert longest(parts) == pytest.approx(best)
    many = split_tours(dist, 6)  # more vehicles than points: some get none
    assert len(many) == 6 and sorted(i for p in many for i in p) == [0, 1, 2, 3]
    assert longest(many) == pytest.approx(10.0)  # the point at 5 alone: 2 x 5 m


def test_truncate_keeps_the_most_rooms_that_fit(plant: World, planner: IndoorPlanner) -> None:
    start = _safe_point(plant)
    rooms = planner.split(start, 1)[0]
    full = planner.route(start, rooms)
    assert truncate_rooms(planner, start, rooms, full.length_m + 1.0).rooms == rooms
    for budget in (full.length_m - 1.0, 0.6 * full.length_m, 0.3 * full.length_m):
        cut = truncate_rooms(planner, start, rooms, budget)
        assert set(cut.rooms) <= set(rooms) and len(cut.rooms) < len(rooms)
        assert cut.length_m <= budget
        # no room left out would have fitted as well
        for extra in set(rooms) - set(cut.rooms):
            more = [*cut.rooms, extra]
            best = min(
                planner.route(start, order).length_m for order in itertools.permutations(more)
            )
            assert best > budget - 1e-6
    nearest = truncate_rooms(planner, start, rooms, 0.3 * full.length_m)
    assert len(nearest.rooms) >= 1  # the room next to the yard fits in 30 %
    none = truncate_rooms(planner, start, rooms, 0.0)
    assert none.rooms == () and none.length_m == 0.0


def test_bad_spec_names_the_field() -> None:
    with pytest.raises(ValueError, match="margin_m"):
        RouteSpec(margin_m=-1.0)
    with pytest.raises(ValueError, match="resolution_m"):
        RouteSpec(resolution_m=0.0)


def test_rooms_of_a_world_without_walls_are_none() -> None:
    world = worlds.build(worlds.load_world(example_path("offshore")))
    assert find_rooms(world) == []
    assert list(itertools.chain(find_rooms(two_rooms()))) != []
