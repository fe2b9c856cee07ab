"""World generators: determinism per seed and the geometry each kind promises."""

import math
from dataclasses import replace

import networkx as nx
import numpy as np
import pytest
import shapely

from worlds import Hotspot, OilSpill, Person, TaskPoint, build, parse_world
from worlds.examples import KINDS
from worlds.maps import cell_of, grid_graph


def _world(kind, seed, extra=""):
    return build(parse_world(f"kind: {kind}\nseed: {seed}\n{extra}"))


def _fingerprint(world):
    return (
        [(s.name, s.center_enu_m, s.size_m, s.yaw_deg, s.rgba) for s in world.solids],
        world.targets,
        world.launch_areas,
        [p.wkb for p in world.no_fly + world.low_interest],
        world.boundary.wkb,
        world.wind,
    )


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_world_other_seed_other_world(kind):
    a, b, c = _world(kind, 11), _world(kind, 11), _world(kind, 12)
    assert _fingerprint(a) == _fingerprint(b)
    assert _fingerprint(a) != _fingerprint(c)


def test_offshore_spills_lie_on_open_sea_and_appear_over_time():
    world = _world("offshore", 3)
    spills = world.targets_of(OilSpill)
    assert len(spills) == 26
    rig_and_tanker = shapely.union_all([s.footprint_at() for s in world.solids])
    sea = world.boundary
    for spill in spills:
        poly = spill.polygon
        assert poly.is_valid and sea.contains(poly)
        assert poly.distance(rig_and_tanker) >= 15.0 - 1e-6
        # Irregular: not a circle, i.e. its area is visibly below that of its bounding circle.
        c = poly.centroid
        r_max = max(math.dist((c.x, c.y), v) for v in spill.outline_xy_m)
        assert poly.area < 0.95 * math.pi * r_max**2
    total = sum(s.polygon.area for s in spills)
    assert shapely.union_all([s.polygon for s in spills]).area == pytest.approx(total)  # disjoint
    times = sorted(s.appear_s for s in spills)
    assert 0.0 <= times[0] < times[-1] <= 120.0
    assert (
        len(world.spills_at(0.0)) < len(world.spills_at(60.0)) < len(world.spills_at(120.0)) == 26
    )
    deck = world.launch_area("helideck")
    assert deck.center_enu_m[2] > 30.0  # above the rig's deck
    assert world.wind is not None and math.isclose(np.hypot(*world.wind.velocity_enu_m_s[:2]), 6.0)


def test_fixing_the_wind_direction_keeps_the_spills():
    drawn = _world("offshore", 4)
    fixed = _world("offshore", 4, "wind_from_deg: 270.0\n")
    assert fixed.wind.from_direction_deg == 270.0 != drawn.wind.from_direction_deg
    assert fixed.targets == drawn.targets


def test_city_buildings_do_not_overlap_and_the_land_base_is_clear():
    world = _world("city", 5)
    footprints = [s.footprint_at() for s in world.solids]
    assert len(footprints) == 15 * 4  # 4 x 4 blocks, one a plaza, 2 x 2 lots each
    assert math.isclose(
        shapely.union_all(footprints).area, sum(f.area for f in footprints), rel_tol=1e-9
    )
    heights = [s.size_m[2] for s in world.solids]
    assert 10.0 <= min(heights) < max(heights) <= 80.0
    base = world.launch_area("land_base")
    pad = shapely.Point(base.center_enu_m[:2]).buffer(base.radius_m)
    assert not any(pad.intersects(f) for f in footprints)


def test_city_hotspots_move_and_stay_inside():
    world = _world("city", 5)
    hotspots = world.targets_of(Hotspot)
    assert len(hotspots) == 5
    x0, y0, x1, y1 = world.bounds_xy_m
    for h in hotspots:
        path = np.array([h.center_at(t) for t in np.arange(0.0, 3600.0, 10.0)])
        assert np.all(path[:, 0] - h.radius_m >= x0 - 1e-9) and np.all(
            path[:, 0] + h.radius_m <= x1 + 1e-9
        )
        assert np.all(path[:, 1] - h.radius_m >= y0 - 1e-9) and np.all(
            path[:, 1] + h.radius_m <= y1 + 1e-9
        )
        speed = np.hypot(*h.velocity_xy_m_s)
        assert math.dist(h.center_at(0.0), h.center_at(1.0)) == pytest.approx(speed, rel=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_indoor_every_person_is_reachable_from_the_safe_point(seed):
    world = _world("indoor", seed)
    assert world.gps_denied
    graph = grid_graph(world, 0.25, altitude_m=1.5)
    origin, res = graph.graph["origin_xy_m"], graph.graph["resolution_m"]
    safe = cell_of(world.launch_area("safe_point").center_enu_m[:2], origin, res)
    reachable = nx.node_connected_component(graph, safe)
    people = world.targets_of(Person)
    assert len(people) == 4
    for person in people:
        assert cell_of(person.position_enu_m[:2], origin, res) in reachable


def test_indoor_walls_enclose_the_rooms_without_doorways():
    """Close the doorways (full walls) and the safe point reaches no person: walls enclose."""
    world = _world("indoor", 0)
    px, py = world.extras["plant_size_x_m"], world.extras["plant_size_y_m"]
    sealed_walls = []
    for s in world.solids:
        if s.name != "wall":
            continue
        along_x = s.size_m[0] > s.size_m[1]
        length = px if along_x else py
        size = (length, s.size_m[1], s.size_m[2]) if along_x else (s.size_m[0], length, s.size_m[2])
        center = (
            (0.0, s.center_enu_m[1], s.center_enu_m[2])
            if along_x
            else (s.center_enu_m[0], 0.0, s.center_enu_m[2])
        )
        sealed_walls.append(replace(s, center_enu_m=center, size_m=size))
    sealed = replace(world, solids=tuple(sealed_walls))
    graph = grid_graph(sealed, 0.25, altitude_m=1.5)
    safe = cell_of(
        world.launch_area("safe_point").center_enu_m[:2], graph.graph["origin_xy_m"], 0.25
    )
    reachable = nx.node_connected_component(graph, safe)
    for person in world.targets_of(Person):
        assert cell_of(person.position_enu_m[:2], graph.graph["origin_xy_m"], 0.25) not in reachable


def test_arena_aco_is_one_km_and_its_movers_move_with_time():
    world = _world("arena_aco", 4)
    assert world.size_m == (1000.0, 1000.0)
    movers = [s for s in world.solids if s.motion is not None]
    static = [s for s in world.solids if s.motion is None]
    assert len(movers) == 8 and len(static) == 25
    for m in movers:
        p0, p1 = np.array(m.center_at(0.0)), np.array(m.center_at(10.0))
        assert np.hypot(*(p1 - p0)[:2]) > 5.0  # >= 1 m/s for 10 s, less a possible bounce
        for t in np.arange(0.0, 2000.0, 7.0):
            x, y, _ = m.center_at(t)
            r = m.size_m[0] / 2.0
            assert abs(x) + r <= 500.0 + 1e-9
            assert abs(y) + r <= 500.0 + 1e-9
    start, goal = world.launch_area("start"), world.launch_area("goal")
    for area in (start, goal):
        zone = shapely.Point(area.center_enu_m[:2]).buffer(area.radius_m)
        assert not any(zone.intersects(s.footprint_at()) for s in static)


def test_arena_aco_zone_separation_and_drum_region_place_zones_and_confine_drums():
    """The zones sit +-separation/2 on the east axis; drums start and stay in their region."""
    region = (-100.0, -30.0, 100.0, 30.0)
    world = _world(
        "arena_aco",
        5,
        "zone_separation_m: 300\nmoving_obstacle_count: 20\n"
        f"moving_obstacle_region_m: {list(region)}\n",
    )
    assert world.launch_area("start").center_enu_m[:2] == (-150.0, 0.0)
    assert world.launch_area("goal").center_enu_m[:2] == (150.0, 0.0)
    movers = [s for s in world.solids if s.motion is not None]
    assert len(movers) == 20
    for m in movers:
        r = m.size_m[0] / 2.0
        for t in np.arange(0.0, 600.0, 3.0):
            x, y, _ = m.center_at(t)
            assert region[0] + r - 1e-9 <= x <= region[2] - r + 1e-9
            assert region[1] + r - 1e-9 <= y <= region[3] - r + 1e-9
    # without the new fields the draws are as before: the default world is unchanged
    assert _fingerprint(_world("arena_aco", 4)) == _fingerprint(
        _world("arena_aco", 4, "zone_separation_m: 800\n")
    )


@pytest.mark.parametrize(
    ("extra", "field"),
    [
        ("zone_separation_m: 990\n", "zone_separation_m"),
        ("zone_separation_m: 50\n", "zone_separation_m"),
        ("moving_obstacle_region_m: [-600, -10, 0, 10]\n", "moving_obstacle_region_m"),
        ("moving_obstacle_region_m: [-5, -100, 4, 100]\n", "moving_obstacle_region_m"),
    ],
)
def test_arena_aco_zones_or_region_that_do_not_fit_fail_naming_the_field(extra, field):
    with pytest.raises(ValueError, match=field):
        parse_world(f"kind: arena_aco\nseed: 0\n{extra}")


def test_workspace_mco_has_holes_and_low_interest_zones_inside():
    world = _world("workspace_mco", 8)
    assert (
        len(world.boundary.interiors) == 2
        and len(world.no_fly) == 2
        and len(world.low_interest) == 3
    )
    outline = shapely.Polygon(world.boundary.exterior)
    for zone in world.low_interest + world.no_fly:
        assert outline.contains(zone)
    for zone in world.low_interest:
        assert world.boundary.contains(zone)  # flyable, just of low interest
    assert 20e4 < world.boundary.area < 70e4  # seed 004's workspaces are 27-70 ha


def test_taskmap_tasks_on_distinct_grid_vertices():
    world = _world("taskmap", 9, "task_count: 30\ndemand: [1, 5]\n")
    tasks = world.targets_of(TaskPoint)
    assert len(tasks) == 30
    xy = np.array([t.position_xy_m for t in tasks])
    assert len({tuple(p) for p in xy}) == 30
    assert np.allclose((xy + 5.0) / 0.5, np.round((xy + 5.0) / 0.5))
    assert all(1.0 <= t.demand <= 5.0 for t in tasks)
    assert len(world.launch_areas) == 10


@pytest.mark.parametrize("kind", KINDS)
def test_box_solids_fit_the_simulators_box_obstacle(kind):
    """What ``sitl`` will build: each box maps field for field onto ``BoxObstacle``."""
    from sitl.physics.obstacles import BoxObstacle

    world = _world(kind, 0)
    for solid in world.solids_at(30.0):
        if solid.shape == "box":
            box = BoxObstacle(solid.center_enu_m, solid.size_m, solid.yaw_deg, solid.rgba)
            assert box.size_m == solid.size_m
        else:
            assert solid.size_m[0] == solid.size_m[1] > 0
