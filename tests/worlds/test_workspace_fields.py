"""Seed 004's workspaces: explicit outlines, holes and zones of low interest in a world file."""

import math
import re

import pytest
from shapely.geometry import Point

from worlds import WorldSpecError, build, load_world, parse_world
from worlds.examples import FIELDS, example_path

AREA_HA = {"mco_rejoya": 70.0, "mco_urban": 54.0, "mco_naranjos": 27.0}
"""The paper's areas (Sec. 5)."""


@pytest.mark.parametrize("name", FIELDS)
def test_the_shipped_fields_have_the_papers_areas_and_a_take_off_point_inside(name: str) -> None:
    world = build(load_world(example_path(name)))
    assert math.isclose(world.boundary.area / 1e4, AREA_HA[name], rel_tol=0.01)
    (start,) = world.launch_areas
    assert start.name == "start"
    assert world.boundary.contains(Point(start.center_enu_m[:2]).buffer(start.radius_m))
    assert world.low_interest, "each field has zones of low interest"
    for zone in world.low_interest:
        assert world.boundary.contains(zone)


SQUARE = "[[-100, -100], [100, -100], [100, 100], [-100, 100]]"


def _field(extra: str) -> str:
    return f"kind: workspace_mco\nseed: 0\nsize_m: [300, 300]\noutline_m: {SQUARE}\n{extra}"


def test_an_explicit_outline_with_a_hole_and_a_zone_builds_exactly() -> None:
    world = build(parse_world(_field(
        "holes_m: [[[-10, -10], [10, -10], [10, 10], [-10, 10]]]\n"
        "low_interest_m: [[[40, 40], [60, 40], [60, 60]]]\n"
        "launch_m: [-50, -50]\n"
    )))  # fmt: skip
    assert world.boundary.area == pytest.approx(200 * 200 - 20 * 20)
    assert world.no_fly[0].area == pytest.approx(400)
    assert world.low_interest[0].area == pytest.approx(200)
    assert world.launch_areas[0].center_enu_m == (-50.0, -50.0, 0.0)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("holes_m: [[[150, 150], [160, 150], [160, 160]]]\n", "holes_m[0]: not inside outline_m"),
        ("low_interest_m: [[[0, 0], [10, 10], [10, 0], [0, 10]]]\n",
         "low_interest_m[0]: not a simple"),
        ("launch_m: [500, 0]\n", "launch_m"),
        ("holes_m: [[[0, 0], [20, 0], [20, 20], [0, 20]],"
         " [[10, 10], [30, 10], [30, 30], [10, 30]]]\n", "holes_m[0] and holes_m[1] overlap"),
    ],
)  # fmt: skip
def test_bad_geometry_is_an_error_naming_the_field(extra: str, message: str) -> None:
    with pytest.raises((ValueError, WorldSpecError), match=re.escape(message)):
        build(parse_world(_field(extra)))


def test_an_outline_outside_the_extent_or_zones_without_an_outline_are_rejected() -> None:
    with pytest.raises(ValueError, match="outside the extent size_m"):
        build(parse_world(_field("").replace("size_m: [300, 300]", "size_m: [100, 100]")))
    with pytest.raises(WorldSpecError, match="need an explicit outline_m"):
        parse_world("kind: workspace_mco\nseed: 0\nholes_m: [[[0, 0], [1, 0], [1, 1]]]\n")
