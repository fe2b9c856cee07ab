"""Planner-map exports: grid, polygons, free space and graph agree with each other and the world."""

import math

import networkx as nx
import numpy as np
import pytest
import shapely

from worlds import build, parse_world
from worlds.examples import KINDS
from worlds.maps import (
    cell_of,
    free_space,
    grid_graph,
    obstacle_polygons,
    occupancy_grid,
    visibility_graph,
)


def _world(kind, seed=2):
    return build(parse_world(f"kind: {kind}\nseed: {seed}\n"))


@pytest.mark.parametrize("kind", ["offshore", "city", "indoor", "arena_aco", "workspace_mco"])
def test_grid_and_polygons_agree(kind):
    world = _world(kind)
    res = max(world.size_m) / 150.0
    grid, origin, r = occupancy_grid(world, res)
    assert r == res and origin == world.bounds_xy_m[:2]
    polys = obstacle_polygons(world)
    blocked = shapely.union_all(polys)
    rows, cols = np.indices(grid.shape)
    xs, ys = origin[0] + (cols + 0.5) * res, origin[1] + (rows + 0.5) * res
    inside_obstacle = shapely.contains_xy(blocked, xs, ys)
    outside = ~shapely.contains_xy(world.boundary, xs, ys)
    assert np.all(grid[inside_obstacle]) and np.all(grid[outside])
    # Away from edges (half a cell), every blocked cell is in an obstacle or outside the boundary.
    edge = shapely.union_all([blocked.boundary, world.boundary.boundary]).buffer(res)
    clear_of_edges = ~shapely.contains_xy(edge, xs, ys)
    assert np.array_equal(grid[clear_of_edges], (inside_obstacle | outside)[clear_of_edges])
    # Blocked fraction matches the blocked area within the rasterisation error.
    area = world.size_m[0] * world.size_m[1]
    expected = 1.0 - free_space(world).area / area
    assert grid.mean() == pytest.approx(expected, abs=0.02)


def test_altitude_filters_solids():
    world = _world("city", 5)
    low = obstacle_polygons(world, altitude_m=5.0)
    high = obstacle_polygons(world, altitude_m=50.0)
    assert len(low) == len(world.solids)
    assert len(high) == sum(s.size_m[2] >= 50.0 for s in world.solids) < len(low)
    assert obstacle_polygons(world, altitude_m=200.0) == []
    indoor = _world("indoor", 0)
    pipes = [s for s in indoor.solids if s.name.startswith("pipe_")]
    pipe_fp = shapely.union_all([p.footprint_at() for p in pipes])
    under = shapely.union_all(obstacle_polygons(indoor, altitude_m=1.5))
    at_pipes = shapely.union_all(obstacle_polygons(indoor, altitude_m=4.5))
    assert at_pipes.contains(pipe_fp.buffer(-0.01)) and not under.contains(pipe_fp.buffer(-0.01))


def test_moving_obstacles_move_in_the_maps():
    world = _world("arena_aco", 4)
    g0, _, _ = occupancy_grid(world, 5.0, altitude_m=None, t_s=0.0)
    g1, _, _ = occupancy_grid(world, 5.0, altitude_m=None, t_s=60.0)
    assert g0.sum() > 0 and not np.array_equal(g0, g1)
    static_only = [s for s in world.solids if s.motion is None]
    s0 = shapely.union_all([s.footprint_at() for s in static_only])
    p0 = shapely.union_all(obstacle_polygons(world, t_s=0.0)).difference(s0)
    p1 = shapely.union_all(obstacle_polygons(world, t_s=60.0)).difference(s0)
    assert p0.area == pytest.approx(p1.area, rel=1e-6) and not p0.equals(p1)


def test_grid_graph_nodes_edges_and_weights():
    world = _world("city", 1)
    res = 6.0
    grid, origin, _ = occupancy_grid(world, res, altitude_m=10.0)
    graph = grid_graph(world, res, altitude_m=10.0)
    assert graph.number_of_nodes() == int((~grid).sum())
    for (r, c), data in list(graph.nodes(data=True))[:50]:
        assert not grid[r, c]
        assert data["pos"] == pytest.approx(
            (origin[0] + (c + 0.5) * res, origin[1] + (r + 0.5) * res)
        )
    weights = {round(w, 9) for _, _, w in graph.edges(data="weight")}
    assert weights == {round(res, 9), round(res * math.sqrt(2), 9)}
    for a, b in graph.edges():
        assert max(abs(a[0] - b[0]), abs(a[1] - b[1])) == 1
        if a[0] != b[0] and a[1] != b[1]:  # diagonal: no corner cutting
            assert not grid[a[0], b[1]] and not grid[b[0], a[1]]
    # Streets connect the whole city: one component, and a path from the land base across it.
    assert nx.number_connected_components(graph) == 1
    base = cell_of(world.launch_area("land_base").center_enu_m[:2], origin, res)
    far = max(graph.nodes, key=lambda n: abs(n[0] - base[0]) + abs(n[1] - base[1]))
    length = nx.shortest_path_length(graph, base, far, weight="weight")
    assert length >= math.dist(graph.nodes[base]["pos"], graph.nodes[far]["pos"]) - 1e-9


def test_clearance_shrinks_free_space_and_bad_arguments_fail():
    world = _world("indoor", 0)
    assert free_space(world, 1.5, clearance_m=0.5).area < free_space(world, 1.5).area
    with pytest.raises(ValueError, match="resolution_m"):
        occupancy_grid(world, 0.0)
    with pytest.raises(ValueError, match="clearance_m"):
        free_space(world, clearance_m=-1.0)


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_exports_maps(kind):
    world = _world(kind)
    graph = grid_graph(world, max(world.size_m) / 60.0, altitude_m=2.0)
    assert graph.number_of_nodes() > 0
    assert nx.number_connected_components(graph) >= 1


def test_visibility_graph_paths_are_free_and_not_longer_than_grid_paths():
    world = build(parse_world("kind: city\nseed: 3\nblocks: [3, 3]\nsize_m: [300, 300]\n"))
    x0, y0, x1, y1 = world.bounds_xy_m
    start, goal = (x0 + 5.0, y0 + 5.0), (x1 - 5.0, y1 - 5.0)
    vis = visibility_graph(world, altitude_m=5.0, points_xy_m=[start, goal])
    free = free_space(world, 5.0).buffer(1e-6)
    for a, b in vis.edges():
        seg = shapely.LineString([vis.nodes[a]["pos"], vis.nodes[b]["pos"]])
        assert free.covers(seg)
    assert not vis.has_edge(0, 1)  # buildings block the diagonal
    path = nx.shortest_path(vis, 0, 1, weight="weight")
    length = nx.path_weight(vis, path, "weight")
    res = 3.0
    grid = grid_graph(world, res, altitude_m=5.0)
    origin = grid.graph["origin_xy_m"]
    grid_len = nx.shortest_path_length(
        grid, cell_of(start, origin, res), cell_of(goal, origin, res), weight="weight"
    )
    assert math.dist(start, goal) < length <= grid_len + 2 * res
