"""Per-item upload checks (MISSION_ACK results) and PX4's feasibility check of a mission."""

import math
import re

import pytest
from mission_helpers import (
    ALT0,
    GLOBAL,
    LAT0,
    LON0,
    MISSION,
    RELATIVE,
    circle,
    item,
    square,
    waypoint,
)
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.feasibility import (
    ItemRejected,
    PlanContext,
    check_fence_plan,
    check_item,
    mission_feasibility,
)
from autopilot_emu.mission.geofence import (
    CIRCLE_INCLUSION,
    POLYGON_INCLUSION,
    RETURN_POINT,
    Fence,
    build_fence,
)
from autopilot_emu.mission.items import MissionItem, MissionType

M = mavlink2
HOME = (LAT0, LON0, ALT0)


def rejection(kind, it, seq=3):
    with pytest.raises(ItemRejected) as error:
        check_item(kind, it, seq)
    assert error.value.seq == seq
    return error.value.result


def do_jump(target, repeat):
    return item(M.MAV_CMD_DO_JUMP, params=(target, repeat, 0.0, 0.0), frame=MISSION)


# -- check_item ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "it",
    [
        waypoint(10.0, 0.0),
        waypoint(10.0, 0.0, 500.0, frame=GLOBAL),
        item(M.MAV_CMD_NAV_LAND, 0.0, 5.0, math.nan, frame=RELATIVE),  # land: altitude optional
        item(M.MAV_CMD_NAV_TAKEOFF, z=10.0, frame=RELATIVE),  # 0/0: here
        item(M.MAV_CMD_NAV_RETURN_TO_LAUNCH, frame=MISSION),
        item(M.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, 3.0, -1.0, 0.0), frame=MISSION),
        item(M.MAV_CMD_NAV_DELAY, params=(2.0, -1.0, -1.0, -1.0), frame=MISSION),
        item(M.MAV_CMD_DO_SET_ROI_LOCATION, 20.0, 20.0, 0.0),
        item(M.MAV_CMD_IMAGE_START_CAPTURE, frame=MISSION),
        do_jump(0, -1),
        do_jump(1, 0),
    ],
)
def test_valid_mission_items_pass(it):
    """Items the navigator can fly are accepted."""
    check_item(MissionType.MISSION, it, 0)


@pytest.mark.parametrize(
    "it",
    [
        item(POLYGON_INCLUSION, 10.0, 0.0, params=(4.0, 0.0, 0.0, 0.0)),
        circle(CIRCLE_INCLUSION, 20.0),
        item(RETURN_POINT, 10.0, 0.0, 30.0),
        item(M.MAV_CMD_NAV_RALLY_POINT, 10.0, 0.0, 30.0),
    ],
)
def test_fence_or_rally_item_in_a_mission_is_a_mission_error(it):
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_ERROR


@pytest.mark.parametrize("command", [M.MAV_CMD_USER_1, 12345, M.MAV_CMD_NAV_LOITER_TURNS])
def test_unknown_command_is_unsupported(command):
    assert rejection(MissionType.MISSION, item(command, frame=MISSION)) == M.MAV_MISSION_UNSUPPORTED


@pytest.mark.parametrize(
    "frame",
    [MISSION, M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_BODY_FRD],
)
def test_position_item_needs_a_global_frame(frame):
    """Waypoints, landings and ROIs in the mission frame or a terrain/local frame are refused."""
    for command in (M.MAV_CMD_NAV_WAYPOINT, M.MAV_CMD_NAV_LAND, M.MAV_CMD_DO_SET_ROI_LOCATION):
        it = item(command, 10.0, 0.0, 10.0, frame=frame)
        assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_UNSUPPORTED_FRAME


def test_item_without_position_may_use_the_mission_frame_but_not_a_local_one():
    speed = (1.0, 3.0, -1.0, 0.0)
    check_item(MissionType.MISSION, item(M.MAV_CMD_DO_CHANGE_SPEED, params=speed, frame=MISSION), 0)
    it = item(M.MAV_CMD_DO_CHANGE_SPEED, params=speed, frame=M.MAV_FRAME_LOCAL_NED)
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_UNSUPPORTED_FRAME


@pytest.mark.parametrize(
    ("x", "y", "result"),
    [
        (900_000_001, 85_000_000, M.MAV_MISSION_INVALID_PARAM5_X),
        (-900_000_001, 85_000_000, M.MAV_MISSION_INVALID_PARAM5_X),
        (473_977_420, 1_800_000_001, M.MAV_MISSION_INVALID_PARAM6_Y),
        (473_977_420, -1_800_000_001, M.MAV_MISSION_INVALID_PARAM6_Y),
    ],
)
def test_latitude_longitude_out_of_range(x, y, result):
    it = MissionItem(M.MAV_CMD_NAV_WAYPOINT, RELATIVE, (0.0, 0.0, 0.0, math.nan), x, y, 10.0)
    assert rejection(MissionType.MISSION, it) == result
    for kind, command in [
        (MissionType.FENCE, RETURN_POINT),
        (MissionType.RALLY, M.MAV_CMD_NAV_RALLY_POINT),
    ]:
        it = MissionItem(command, RELATIVE, (0.0, 0.0, 0.0, 0.0), x, y, 10.0)
        assert rejection(kind, it) == result


def test_latitude_longitude_at_the_limits_are_valid():
    it = MissionItem(
        M.MAV_CMD_NAV_WAYPOINT, RELATIVE, (0.0,) * 4, 900_000_000, -1_800_000_000, 10.0
    )
    check_item(MissionType.MISSION, it, 0)


@pytest.mark.parametrize("z", [math.nan, math.inf, -math.inf])
def test_waypoint_without_a_finite_altitude_is_invalid_param7(z):
    assert rejection(MissionType.MISSION, waypoint(10.0, 0.0, z)) == M.MAV_MISSION_INVALID_PARAM7


def test_landing_may_have_no_altitude_but_not_an_infinite_one():
    land = M.MAV_CMD_NAV_LAND
    check_item(MissionType.MISSION, item(land, 10.0, 0.0, math.nan, frame=RELATIVE), 0)
    it = item(land, 10.0, 0.0, math.inf, frame=RELATIVE)
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_INVALID_PARAM7


@pytest.mark.parametrize("target", [-1.0, 1.5, math.nan])
def test_do_jump_bad_target_is_invalid_param1(target):
    assert rejection(MissionType.MISSION, do_jump(target, 1)) == M.MAV_MISSION_INVALID_PARAM1


@pytest.mark.parametrize("repeat", [-2.0, 0.5, math.nan])
def test_do_jump_bad_repeat_count_is_invalid_param2(repeat):
    assert rejection(MissionType.MISSION, do_jump(0, repeat)) == M.MAV_MISSION_INVALID_PARAM2


def test_nav_delay_time_of_day_is_invalid_param1():
    """param1 = -1 asks for a UTC time of day, which the emulator cannot wait for."""
    it = item(M.MAV_CMD_NAV_DELAY, params=(-1.0, 12.0, 0.0, 0.0), frame=MISSION)
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_INVALID_PARAM1


def test_negative_hold_time_is_invalid_param1():
    it = waypoint(10.0, 0.0, params=(-3.0, 0.0, 0.0, math.nan))
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_INVALID_PARAM1


@pytest.mark.parametrize("index", [0, 1, 2, 3])
def test_infinite_param_is_refused_with_its_index(index):
    params = [0.0, 0.0, 0.0, math.nan]
    params[index] = math.inf
    it = waypoint(10.0, 0.0, params=tuple(params))
    assert rejection(MissionType.MISSION, it) == M.MAV_MISSION_INVALID_PARAM1 + index


@pytest.mark.parametrize("count", [2.0, 0.0, 3.5])
def test_fence_polygon_with_fewer_than_three_vertices_is_a_mission_error(count):
    it = item(POLYGON_INCLUSION, 10.0, 0.0, params=(count, 0.0, 0.0, 0.0))
    assert rejection(MissionType.FENCE, it) == M.MAV_MISSION_ERROR


def test_fence_circle_radius_must_not_be_negative():
    assert rejection(MissionType.FENCE, circle(CIRCLE_INCLUSION, -1.0, 1.0, 1.0)) == (
        M.MAV_MISSION_INVALID_PARAM1
    )


def test_waypoint_in_a_fence_or_rally_plan_is_unsupported():
    for kind in (MissionType.FENCE, MissionType.RALLY):
        assert rejection(kind, waypoint(10.0, 0.0)) == M.MAV_MISSION_UNSUPPORTED


def test_fence_item_in_a_rally_plan_is_unsupported():
    assert rejection(MissionType.RALLY, circle(CIRCLE_INCLUSION, 20.0, 1.0, 1.0)) == (
        M.MAV_MISSION_UNSUPPORTED
    )


def test_fence_and_rally_items_need_a_global_frame():
    rally = item(M.MAV_CMD_NAV_RALLY_POINT, 10.0, 0.0, 30.0, frame=M.MAV_FRAME_LOCAL_NED)
    assert rejection(MissionType.RALLY, rally) == M.MAV_MISSION_UNSUPPORTED_FRAME
    vertex = item(POLYGON_INCLUSION, 10.0, 0.0, params=(3.0, 0, 0, 0), frame=MISSION)
    assert rejection(MissionType.FENCE, vertex) == M.MAV_MISSION_UNSUPPORTED_FRAME


def test_complete_fence_with_short_polygon_is_a_mission_error_at_its_first_vertex():
    plan = (circle(CIRCLE_INCLUSION, 50.0), *square(POLYGON_INCLUSION, 20.0)[:3])
    with pytest.raises(ItemRejected) as error:
        check_fence_plan(plan)
    assert (error.value.result, error.value.seq) == (M.MAV_MISSION_ERROR, 1)
    check_fence_plan(tuple(square(POLYGON_INCLUSION, 20.0)))


# -- mission_feasibility -----------------------------------------------------------------------


def context(fence=None, home=HOME, hor=0.0, ver=0.0, dist_1wp=0.0):
    return PlanContext(home, fence or Fence(), hor, ver, dist_1wp)


def test_mission_inside_the_fence_is_feasible():
    fence = build_fence(tuple(square(POLYGON_INCLUSION, 20.0)))
    result = mission_feasibility((waypoint(10.0, 0.0), waypoint(0.0, 10.0)), context(fence))
    assert result.problem is None and result.warnings == ()


def test_waypoint_outside_the_fence_is_a_geofence_violation_numbered_from_one():
    fence = build_fence(tuple(square(POLYGON_INCLUSION, 20.0)))
    plan = (waypoint(10.0, 0.0), waypoint(30.0, 0.0), waypoint(0.0, 30.0))
    assert mission_feasibility(plan, context(fence)).problem == "Geofence violation for waypoint 2"


def test_landing_inside_an_exclusion_area_is_a_geofence_violation():
    fence = build_fence((circle(mavlink2.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, 15.0, 50.0, 0.0),))
    land = item(M.MAV_CMD_NAV_LAND, 55.0, 0.0, math.nan, frame=RELATIVE)
    result = mission_feasibility((waypoint(0.0, 10.0), land), context(fence))
    assert result.problem == "Geofence violation for waypoint 2"


def test_waypoint_beyond_gf_max_hor_dist_is_refused():
    plan = (waypoint(30.0, 40.0),)  # 50 m from home
    assert mission_feasibility(plan, context(hor=60.0)).problem is None
    problem = mission_feasibility(plan, context(hor=45.0)).problem
    assert problem is not None and "waypoint 1" in problem and "GF_MAX_HOR_DIST" in problem


def test_waypoint_beyond_gf_max_ver_dist_is_refused_in_both_altitude_frames():
    assert mission_feasibility((waypoint(10.0, 0.0, 40.0),), context(ver=50.0)).problem is None
    for it in [waypoint(10.0, 0.0, 60.0), waypoint(10.0, 0.0, ALT0 + 60.0, frame=GLOBAL)]:
        problem = mission_feasibility((waypoint(0.0, 10.0), it), context(ver=50.0)).problem
        assert problem is not None and "waypoint 2" in problem and "GF_MAX_VER_DIST" in problem


def test_relative_altitude_without_home_is_refused_but_amsl_is_not():
    plan = (waypoint(10.0, 0.0, ALT0 + 10.0, frame=GLOBAL), waypoint(20.0, 0.0))
    problem = mission_feasibility(plan, context(home=None)).problem
    assert problem is not None and "WP 2" in problem and "home" in problem.lower()
    assert mission_feasibility(plan[:1], context(home=None)).problem is None


def test_first_waypoint_far_away_only_warns():
    """MIS_DIST_1WP: a warning for the first position item only, the mission stays valid."""
    plan = (
        item(M.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, 3.0, -1.0, 0.0), frame=MISSION),
        waypoint(300.0, 400.0),  # 500 m
        waypoint(600.0, 800.0),  # 1000 m, not the first
    )
    result = mission_feasibility(plan, context(dist_1wp=100.0))
    assert result.problem is None
    assert len(result.warnings) == 1
    reported = re.search(r"(\d+) ?m", result.warnings[0])
    assert reported is not None and float(reported.group(1)) == pytest.approx(500.0, rel=0.005)
    assert mission_feasibility(plan, context(dist_1wp=600.0)).warnings == ()
    assert mission_feasibility(plan, context(dist_1wp=0.0)).warnings == ()


def test_do_jump_beyond_the_end_is_refused():
    plan = (waypoint(10.0, 0.0), waypoint(20.0, 0.0), do_jump(3, 1))
    problem = mission_feasibility(plan, context()).problem
    assert problem is not None and "DO_JUMP" in problem and "item 3" in problem
    assert mission_feasibility((*plan[:2], do_jump(1, 1)), context()).problem is None
