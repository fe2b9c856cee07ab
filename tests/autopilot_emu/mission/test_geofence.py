"""Geofence semantics (PX4 navigator/geofence.cpp) and rejection of malformed fence plans."""

import math

import pytest
from mission_helpers import circle, item, offset, polygon, square, waypoint

from autopilot_emu.mission.geofence import (
    CIRCLE_EXCLUSION,
    CIRCLE_INCLUSION,
    POLYGON_EXCLUSION,
    POLYGON_INCLUSION,
    RETURN_POINT,
    FenceError,
    build_fence,
)


def inside(fence, north_m, east_m):
    return fence.contains(*offset(north_m, east_m))


def test_point_10_m_from_centre_of_40_m_square_is_inside_and_30_m_is_outside():
    """A 40 m inclusion square holds points 10 m from its centre, not 30 m, in every direction."""
    fence = build_fence(tuple(square(POLYGON_INCLUSION, 20.0)))
    for north, east in [(10, 0), (0, 10), (-10, 0), (0, -10), (10, 10), (-10, -10)]:
        assert inside(fence, north, east), (north, east)
    for north, east in [(30, 0), (0, 30), (-30, 0), (0, -30), (19, 21), (21, 19)]:
        assert not inside(fence, north, east), (north, east)


def test_inside_any_of_several_inclusion_areas_is_inside():
    """Inclusion areas are a union: a point in the second area only is still inside."""
    plan = (*square(POLYGON_INCLUSION, 20.0), circle(CIRCLE_INCLUSION, 15.0, north_m=100.0))
    fence = build_fence(plan)
    assert inside(fence, 0, 0)
    assert inside(fence, 110, 0)  # 10 m from the circle's centre
    assert not inside(fence, 60, 0)  # between the two
    assert not inside(fence, 100, 20)  # 20 m from the circle's centre


def test_inside_an_exclusion_area_is_outside():
    """An exclusion polygon or circle punches a hole in the inclusion area."""
    plan = (
        *square(POLYGON_INCLUSION, 100.0),
        *square(POLYGON_EXCLUSION, 20.0),
        circle(CIRCLE_EXCLUSION, 10.0, north_m=50.0, east_m=50.0),
    )
    fence = build_fence(plan)
    assert not inside(fence, 10, 0)
    assert not inside(fence, 50, 45)
    assert inside(fence, 30, 0)
    assert inside(fence, 50, 35)


def test_exclusion_areas_alone_allow_everything_outside_them():
    """Without inclusion areas, everywhere outside the exclusions is inside the fence."""
    fence = build_fence((circle(CIRCLE_EXCLUSION, 20.0),))
    assert not inside(fence, 10, 0)
    assert inside(fence, 30, 0)
    assert inside(fence, -5000, 5000)


def test_exclusion_boundary_is_allowed():
    """A point exactly on an exclusion edge (same latitude as two corners) is not excluded."""
    plan = tuple(square(POLYGON_EXCLUSION, 20.0))
    fence = build_fence(plan)
    edge_lat = plan[2].lat_deg  # north edge: corners 2 and 3 share this latitude
    mid_lon = (plan[2].lon_deg + plan[3].lon_deg) / 2
    assert fence.contains(edge_lat, mid_lon)
    assert fence.contains(plan[0].lat_deg, plan[0].lon_deg)  # a corner
    assert not fence.contains(edge_lat - 1e-6, mid_lon)  # 11 cm inside


def test_inclusion_boundary_is_inside():
    """A point on an inclusion edge is inside (the area is closed)."""
    plan = tuple(square(POLYGON_INCLUSION, 20.0))
    fence = build_fence(plan)
    assert fence.contains(plan[2].lat_deg, (plan[2].lon_deg + plan[3].lon_deg) / 2)


def test_empty_fence_contains_everything():
    """No areas: every position is inside, even a return point alone does not fence."""
    for plan in [(), (item(RETURN_POINT, 5.0, 5.0, 20.0),)]:
        fence = build_fence(plan)
        assert fence.empty
        assert inside(fence, 0, 0)
        assert fence.contains(-33.9, 151.2)


def test_return_point_is_kept():
    """NAV_FENCE_RETURN_POINT is stored with its latitude, longitude and altitude."""
    ret = item(RETURN_POINT, 5.0, 5.0, 20.0)
    fence = build_fence((*square(POLYGON_INCLUSION, 20.0), ret))
    assert fence.return_point == pytest.approx((ret.lat_deg, ret.lon_deg, 20.0))


def test_polygon_with_fewer_vertices_than_announced_is_rejected_at_its_first_vertex():
    """A run of 3 vertices announcing 4 is malformed; seq is the polygon's first item."""
    short = square(POLYGON_INCLUSION, 20.0)[:3]
    plan = (circle(CIRCLE_INCLUSION, 50.0), *short)
    with pytest.raises(FenceError) as error:
        build_fence(plan)
    assert error.value.seq == 1


def test_polygon_interrupted_by_another_polygon_is_rejected():
    """Vertices of a polygon must be consecutive items of the same command."""
    inclusion = square(POLYGON_INCLUSION, 20.0)
    exclusion = square(POLYGON_EXCLUSION, 5.0)
    plan = (*inclusion[:2], *exclusion, *inclusion[2:])
    with pytest.raises(FenceError) as error:
        build_fence(plan)
    assert error.value.seq == 0


@pytest.mark.parametrize("count", [2, 0, -3, 3.5, math.nan])
def test_polygon_needs_an_integer_vertex_count_of_at_least_three(count):
    """param1 must be a whole number >= 3."""
    corners = [(0.0, 0.0), (0.0, 20.0), (20.0, 0.0)]
    plan = [item(POLYGON_INCLUSION, n, e, params=(count, 0.0, 0.0, 0.0)) for n, e in corners]
    with pytest.raises(FenceError) as error:
        build_fence((circle(CIRCLE_INCLUSION, 50.0), *plan))
    assert error.value.seq == 1


def test_self_intersecting_polygon_is_rejected():
    """A bow tie (corners in crossing order) is not a valid area."""
    bow_tie = polygon(POLYGON_INCLUSION, [(-20, -20), (20, 20), (-20, 20), (20, -20)])
    with pytest.raises(FenceError) as error:
        build_fence((*square(POLYGON_EXCLUSION, 5.0), *bow_tie))
    assert error.value.seq == 4


def test_degenerate_polygon_is_rejected():
    """Three collinear corners enclose no area."""
    line = polygon(POLYGON_INCLUSION, [(0, 0), (10, 0), (20, 0)])
    with pytest.raises(FenceError):
        build_fence(tuple(line))


@pytest.mark.parametrize("radius", [-5.0, math.nan])
def test_circle_radius_must_not_be_negative(radius):
    """Circle radius (param1) must be a number >= 0."""
    plan = (*square(POLYGON_INCLUSION, 20.0), circle(CIRCLE_EXCLUSION, radius, 5.0, 5.0))
    with pytest.raises(FenceError) as error:
        build_fence(plan)
    assert error.value.seq == 4


def test_zero_radius_circle_is_a_placeholder_that_encloses_nothing():
    """MAVSDK's geofence example sends Circle(Point(0, 0), 0, INCLUSION) for "no circle"."""
    plan = (*square(POLYGON_INCLUSION, 20.0), circle(CIRCLE_INCLUSION, 0.0, 0.0, 0.0))
    fence = build_fence(plan)
    assert len(fence.inclusion) == 1
    assert fence.contains(*offset(5.0, 5.0))
    assert not fence.contains(*offset(30.0, 0.0))


def test_non_fence_command_is_rejected():
    """A waypoint in a fence plan is refused with its seq."""
    plan = (circle(CIRCLE_INCLUSION, 50.0), waypoint(10.0, 0.0))
    with pytest.raises(FenceError) as error:
        build_fence(plan)
    assert error.value.seq == 1
    assert isinstance(error.value, ValueError)
