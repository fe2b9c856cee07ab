"""Spawn points inside launch areas and each kind's default launch area."""

from __future__ import annotations

import itertools
import math

import pytest
import shapely

import worlds
from worlds.examples import example_path
from worlds.launch import default_area, spawn_points
from worlds.maps import free_space

PAD = worlds.LaunchArea("helideck", (10.0, -5.0, 30.0), 8.8)


@pytest.mark.parametrize(("n", "spacing_m"), [(1, 5.0), (7, 3.0), (19, 2.0), (4, 1.0)])
def test_points_are_inside_the_area_on_its_surface_and_spaced(n, spacing_m):
    points = spawn_points(PAD, n, spacing_m)
    assert len(points) == n
    cx, cy, cz = PAD.center_enu_m
    assert points[0] == (cx, cy, cz)  # the first vehicle on the centre
    for x, y, z in points:
        assert math.hypot(x - cx, y - cy) <= PAD.radius_m + 1e-9
        assert z == cz
    for a, b in itertools.combinations(points, 2):
        assert math.dist(a, b) >= spacing_m - 1e-9


def test_too_many_vehicles_name_the_area_its_radius_and_n():
    with pytest.raises(ValueError, match=r"'helideck' \(radius 8\.8 m\) cannot hold 32 vehicles"):
        spawn_points(PAD, 32, 3.0)  # hexagonal lattice norms 0, 1, 1.73, 2, 2.65 < 8.8 / 3
    assert len(spawn_points(PAD, 31, 3.0)) == 31


@pytest.mark.parametrize(("n", "spacing_m"), [(0, 5.0), (2, 0.0), (2, float("nan"))])
def test_bad_arguments_are_refused(n, spacing_m):
    with pytest.raises(ValueError):
        spawn_points(PAD, n, spacing_m)


@pytest.mark.parametrize(
    ("kind", "name"),
    [
        ("offshore", "helideck"),
        ("city", "land_base"),
        ("indoor", "safe_point"),
        ("arena_aco", "start"),
        ("taskmap", "agent_start_0"),
        ("workspace_mco", "origin"),
    ],
)
def test_every_example_has_a_default_area_in_free_space(kind, name):
    world = worlds.build(worlds.load_world(example_path(kind)))
    area = default_area(world)
    assert area.name == name
    x, y, _ = area.center_enu_m

    if area.center_enu_m[2] == 0.0:  # a pad on the ground is clear of every solid
        assert free_space(world).contains(shapely.Point(x, y).buffer(min(area.radius_m, 1.0)))
    else:  # a raised pad is the top of a solid
        assert any(
            s.footprint_at().contains(shapely.Point(x, y))
            and s.center_enu_m[2] + s.size_m[2] / 2.0 == pytest.approx(area.center_enu_m[2])
            for s in world.solids
        )
