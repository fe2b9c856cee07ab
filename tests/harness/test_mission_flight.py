"""Missions, geofence, rally and failsafes flown on the full stack in lockstep.

A raw pymavlink client uploads plans and commands over real UDP to one vehicle of an in-process
Simulation; every wait is in simulated time (the client steps the simulation), so the outcome
does not depend on the machine's load. Positions checked are the autopilot's own estimate.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mission_link import SimLink, mission_cmd, offset_deg, waypoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.items import MissionState
from autopilot_emu.modes import AutoSubMode, LandedState

pytestmark = pytest.mark.sockets

AUTO = 4
FENCE_VERTEX = mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION


@pytest.fixture
def link():
    lk = SimLink.open()
    lk.wait_ready()
    yield lk
    lk.close()


def reached(lk: SimLink) -> list[int]:
    return [m.seq for m in lk.inbox if m.get_type() == "MISSION_ITEM_REACHED"]


def fence_square(half_side_m: float) -> list[mavlink2.MAVLink_message]:
    corners = [
        (half_side_m, half_side_m),
        (half_side_m, -half_side_m),
        (-half_side_m, -half_side_m),
        (-half_side_m, half_side_m),
    ]
    items = []
    for n, e in corners:
        lat, lon = offset_deg(n, e)
        items.append(
            mavlink2.MAVLink_mission_item_int_message(
                1,
                1,
                0,
                mavlink2.MAV_FRAME_GLOBAL_INT,
                FENCE_VERTEX,
                0,
                1,
                4,
                0,
                0,
                0,
                round(lat * 1e7),
                round(lon * 1e7),
                0.0,
                1,
            )
        )
    return items


def take_off(lk: SimLink, height_m: float = 5.0) -> None:
    lk.set_param("MIS_TAKEOFF_ALT", height_m)
    assert lk.arm() == 0
    assert lk.command(mavlink2.MAV_CMD_NAV_TAKEOFF) == 0
    lk.until(lambda: lk.commander.sub_mode == AutoSubMode.LOITER, 30)


def goto(lk: SimLink, north_m: float, east_m: float, rel_alt_m: float) -> int:
    lat, lon = offset_deg(north_m, east_m)
    home_alt = lk.commander.home.alt_amsl_m
    lk.send(
        mavlink2.MAVLink_command_int_message(
            1,
            1,
            mavlink2.MAV_FRAME_GLOBAL_INT,
            mavlink2.MAV_CMD_DO_REPOSITION,
            0,
            0,
            -1,
            1,
            0,
            math.nan,
            round(lat * 1e7),
            round(lon * 1e7),
            home_alt + rel_alt_m,
        )
    )
    return lk.wait_type("COMMAND_ACK", command=mavlink2.MAV_CMD_DO_REPOSITION).result


def landed_and_disarmed(lk: SimLink) -> bool:
    cmd = lk.commander
    return not cmd.armed and cmd.landed_state == LandedState.ON_GROUND


def test_mission_from_the_ground_flies_every_item_then_rtl_lands_home(link):
    """Take-off, waypoints with hold and speed change, DO_JUMP once, RTL: all in order."""
    items = [
        waypoint(10, 0, 6, hold_s=2.0),  # 0
        mission_cmd(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 3.0, -1),  # 1
        waypoint(10, 10, 6),  # 2: pass-through
        mission_cmd(mavlink2.MAV_CMD_DO_JUMP, 0, 1),  # 3: back to 0 once
        waypoint(0, 10, 5),  # 4
        mission_cmd(mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH),  # 5
    ]
    assert link.upload(items) == mavlink2.MAV_MISSION_ACCEPTED
    assert link.arm() == 0
    assert link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    visited = []

    def track() -> bool:
        visited.append(link.truth_ned())
        return landed_and_disarmed(link)

    link.until(track, 240, every_s=0.2)
    assert reached(link) == [0, 1, 2, 0, 1, 2, 3, 4, 5]
    path = np.array(visited)
    for n, e in [link.ned_of(10, 0), link.ned_of(10, 10), link.ned_of(0, 10)]:
        assert np.min(np.hypot(path[:, 0] - n, path[:, 1] - e)) < 1.2, (n, e)
    assert -path[:, 2].min() > 5.5  # climbed to the mission altitude first
    assert np.hypot(*path[-1, :2]) < 1.5  # landed at home
    current = [m for m in link.inbox if m.get_type() == "MISSION_CURRENT"][-1]
    assert current.mission_state == MissionState.COMPLETE
    assert "Mission finished, returning to launch" in link.texts


def test_hold_pauses_and_mission_resumes_at_the_same_item(link):
    items = [waypoint(15, 0, 5), waypoint(15, 15, 5), waypoint(0, 15, 5)]
    assert link.upload(items) == 0
    assert link.arm() == 0 and link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    link.until(lambda: 0 in reached(link), 60)
    assert link.set_mode(AUTO, AutoSubMode.LOITER) == 0
    paused_at = link.truth_ned()
    link.run(5.0)
    assert np.hypot(*(np.array(link.truth_ned()[:2]) - paused_at[:2])) < 3.0
    assert link.sim.fleet.commanders[0].mission.state == MissionState.PAUSED
    assert link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    link.until(lambda: 2 in reached(link), 90)
    assert reached(link) == [0, 1, 2]
    n, e, _ = link.truth_ned()
    assert math.hypot(*np.subtract((n, e), link.ned_of(0, 15))) < 1.5


def test_set_current_skips_ahead(link):
    items = [waypoint(20, 0, 5), waypoint(0, 8, 5)]
    assert link.upload(items) == 0
    link.send(mavlink2.MAVLink_mission_set_current_message(1, 1, 1))
    link.wait_type("MISSION_CURRENT", seq=1)
    assert link.arm() == 0 and link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    link.until(lambda: 1 in reached(link), 60)
    assert reached(link) == [1]


def test_land_item_lands_there_and_disarms(link):
    items = [waypoint(8, 0, 4), waypoint(8, 8, 0, command=mavlink2.MAV_CMD_NAV_LAND)]
    assert link.upload(items) == 0
    assert link.arm() == 0 and link.set_mode(AUTO, AutoSubMode.MISSION) == 0
    link.until(lambda: landed_and_disarmed(link), 120)
    n, e, _ = link.truth_ned()
    assert math.hypot(*np.subtract((n, e), link.ned_of(8, 8))) < 1.5
    assert reached(link) == [0, 1]
    assert "Mission finished, landed" in link.texts


def test_mission_outside_the_fence_is_accepted_but_mission_mode_refused(link):
    assert link.upload(fence_square(20), mission_type=1) == 0
    assert link.upload([waypoint(40, 0, 5)]) == 0
    link.until(lambda: any("Geofence violation for waypoint 1" in t for t in link.texts), 2)
    assert link.set_mode(AUTO, AutoSubMode.MISSION) == mavlink2.MAV_RESULT_TEMPORARILY_REJECTED
    current = link.wait_type("MISSION_CURRENT", timeout_s=2)
    assert current.mission_state == MissionState.NO_MISSION
    assert link.upload([waypoint(10, 0, 5)]) == 0
    assert link.set_mode(AUTO, AutoSubMode.MISSION) == 0


def test_geofence_breach_triggers_gf_action_return(link):
    assert link.upload(fence_square(15), mission_type=1) == 0
    sys_status = link.wait_type("SYS_STATUS")
    assert sys_status.onboard_control_sensors_present & mavlink2.MAV_SYS_STATUS_GEOFENCE
    assert sys_status.onboard_control_sensors_health & mavlink2.MAV_SYS_STATUS_GEOFENCE
    link.set_param("GF_ACTION", 3, int32=True)
    link.set_param("RTL_RETURN_ALT", 8.0)
    take_off(link)
    assert goto(link, 30, 0, 5) == 0
    link.until(lambda: link.commander.sub_mode == AutoSubMode.RTL, 30)
    assert "Geofence violation" in link.texts
    assert max(link.truth_ned()[0], 0) < 25  # turned back near the fence, never reached 30 m
    # SYS_STATUS shows the breach (MAVProxy announces "fence breach") while outside.
    link.wait(
        lambda m: (
            m.get_type() == "SYS_STATUS"
            and not m.onboard_control_sensors_health & mavlink2.MAV_SYS_STATUS_GEOFENCE
        ),
        timeout_s=3,
    )
    link.until(lambda: landed_and_disarmed(link), 120)
    assert np.hypot(*link.truth_ned()[:2]) < 1.5


def test_max_horizontal_distance_breach_holds(link):
    link.set_param("GF_MAX_HOR_DIST", 12.0)
    take_off(link)
    assert goto(link, 25, 0, 5) == 0
    link.until(lambda: link.commander.fence_breached, 30)
    link.run(6.0)
    n, _, _ = link.truth_ned()
    # GF_ACTION 2 (default): Hold just past the limit, at the jerk-limited braking distance
    # (v²/2a + 0.6 s x v, 7.2 m at 5 m/s) beyond where the breach was seen.
    assert 12.0 < n < 21.0
    assert link.commander.sub_mode == AutoSubMode.LOITER


def test_rtl_goes_to_the_closest_rally_point(link):
    lat, lon = offset_deg(0, 20)
    rally = mavlink2.MAVLink_mission_item_int_message(
        1,
        1,
        0,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink2.MAV_CMD_NAV_RALLY_POINT,
        0,
        1,
        0,
        0,
        0,
        0,
        round(lat * 1e7),
        round(lon * 1e7),
        10.0,
        2,
    )
    assert link.upload([rally], mission_type=2) == 0
    link.set_param("RTL_RETURN_ALT", 8.0)
    take_off(link)
    assert goto(link, 0, 15, 5) == 0
    link.run(8.0)
    assert link.set_mode(AUTO, AutoSubMode.RTL) == 0
    link.until(lambda: any("rally point 1" in t for t in link.texts), 1)
    link.until(lambda: landed_and_disarmed(link), 120)
    n, e, _ = link.truth_ned()
    assert math.hypot(*np.subtract((n, e), link.ned_of(0, 20))) < 1.5


def test_low_battery_lands_with_com_low_bat_act_land(link):
    link.set_param("BAT1_CAPACITY", 60.0)  # mAh: a few tens of seconds of hover
    link.set_param("COM_LOW_BAT_ACT", 2, int32=True)
    take_off(link)
    link.until(lambda: link.commander.sub_mode == AutoSubMode.LAND, 60)
    assert "Low battery level, return advised" in link.texts
    assert "Critical battery level, land now" in link.texts
    assert any(t.startswith("Failsafe activated") for t in link.texts)
    link.until(lambda: landed_and_disarmed(link), 60)


def test_gps_loss_in_the_air_lands(link):
    link.set_param("SYS_FAILURE_EN", 1, int32=True)
    take_off(link)
    result = link.command(
        mavlink2.MAV_CMD_INJECT_FAILURE,
        mavlink2.FAILURE_UNIT_SENSOR_GPS,
        mavlink2.FAILURE_TYPE_OFF,
        0,
    )
    assert result == 0
    link.until(lambda: link.commander.sub_mode == AutoSubMode.LAND, 10)
    assert "No global position: GPS lost" in link.texts
    link.until(lambda: link.commander.landed_state == LandedState.ON_GROUND, 60)


def test_failure_injection_is_denied_unless_enabled(link):
    result = link.command(
        mavlink2.MAV_CMD_INJECT_FAILURE,
        mavlink2.FAILURE_UNIT_SENSOR_GPS,
        mavlink2.FAILURE_TYPE_OFF,
        0,
    )
    assert result == mavlink2.MAV_RESULT_DENIED


def gcs_heartbeat(lk: SimLink) -> None:
    lk.send(mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_GCS, 8, 0, 0, 4, 3))


def test_data_link_loss_returns_after_com_dl_loss_t(link):
    link.set_param("NAV_DLL_ACT", 2, int32=True)
    link.set_param("COM_DL_LOSS_T", 5, int32=True)
    link.set_param("RTL_RETURN_ALT", 8.0)
    gcs_heartbeat(link)
    # The ground station talks during the take-off too: the jerk-limited climb to 5 m takes
    # longer than COM_DL_LOSS_T.
    link.set_param("MIS_TAKEOFF_ALT", 5.0)
    assert link.arm() == 0 and link.command(mavlink2.MAV_CMD_NAV_TAKEOFF) == 0
    for _ in range(30):
        link.run(1.0)
        gcs_heartbeat(link)
        if link.commander.sub_mode == AutoSubMode.LOITER:
            break
    assert link.commander.sub_mode == AutoSubMode.LOITER
    assert goto(link, 10, 0, 5) == 0
    for _ in range(4):  # the ground station keeps talking: no failsafe
        link.run(1.0)
        gcs_heartbeat(link)
    assert link.commander.sub_mode == AutoSubMode.LOITER
    lost_after = link.until(lambda: link.commander.sub_mode == AutoSubMode.RTL, 20)
    assert 4.0 <= lost_after <= 6.0  # COM_DL_LOSS_T after the last heartbeat, simulated s
    assert "Connection to ground station lost" in link.texts
    gcs_heartbeat(link)
    link.until(lambda: "GCS connection regained" in link.texts, 2)
    link.until(lambda: landed_and_disarmed(link), 120)


def test_data_link_loss_is_off_by_default(link):
    gcs_heartbeat(link)
    take_off(link)
    link.run(15.0)
    assert "Connection to ground station lost" in link.texts
    assert link.commander.sub_mode == AutoSubMode.LOITER and link.commander.in_air


def test_mission_start_command_arms_and_flies_from_the_ground(link):
    """MAV_CMD_MISSION_START (PX4): arms, takes off and flies from the requested item."""
    assert link.upload([waypoint(20, 0, 5), waypoint(6, 6, 5)]) == 0
    assert link.command(mavlink2.MAV_CMD_MISSION_START, 1, 1) == 0
    assert link.commander.armed
    link.until(lambda: 1 in reached(link), 60)
    assert reached(link) == [1]  # started at item 1, item 0 skipped
    n, e, _ = link.truth_ned()
    assert math.hypot(*np.subtract((n, e), link.ned_of(6, 6))) < 1.5


def test_mission_start_without_a_mission_is_denied(link):
    assert link.command(mavlink2.MAV_CMD_MISSION_START, 0, 0) == mavlink2.MAV_RESULT_DENIED
    assert not link.commander.armed
