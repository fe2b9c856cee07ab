"""Commander state machine: PX4's arming rules, mode switching and land detection."""

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.commander import (
    ACCEPTED,
    DENIED,
    TEMPORARILY_REJECTED,
    Commander,
    NavInput,
)
from autopilot_emu.mission.items import MissionItem, MissionState, MissionType
from autopilot_emu.modes import AutoSubMode, LandedState, MainMode
from autopilot_emu.modes.takeoff import MIN_TAKEOFF_HEIGHT_M
from autopilot_emu.params import ParamStore
from autopilot_emu.telemetry import system_status


def nav(t, z=0.0, vz=0.0, ok=True, thrust=0.0):
    return NavInput(t, np.array([0.0, 0.0, z]), np.array([0.0, 0.0, vz]), 0.0, ok, thrust, 488.0)


@pytest.fixture
def cmd():
    c = Commander(ParamStore())
    c.update(nav(0.0))
    return c


def test_arming_needs_a_position_unless_forced():
    c = Commander(ParamStore())
    c.update(nav(0.0, ok=False))
    assert c.arm(False) == DENIED and not c.armed
    assert c.arm(True) == ACCEPTED and c.armed


def test_takeoff_denied_when_disarmed_and_climbs_to_mis_takeoff_alt(cmd):
    assert cmd.takeoff(None) == DENIED
    assert cmd.arm(False) == ACCEPTED
    assert cmd.takeoff(None) == ACCEPTED
    assert (cmd.main_mode, cmd.sub_mode) == (MainMode.AUTO, AutoSubMode.TAKEOFF)
    out = cmd.update(nav(0.1))
    assert out.active
    assert cmd._target[2] == pytest.approx(-2.5)  # MIS_TAKEOFF_ALT default
    # Until lift-off the climb rate ramps (MPC_TKO_RAMP_T) from zero thrust (g / MPC_Z_VEL_P_ACC
    # downwards) to MPC_TKO_SPEED upwards; then the trajectory climbs to the target.
    assert np.isnan(out.position_ned_m[2]) and not out.smooth
    assert out.velocity_ff_m_s[2] == pytest.approx(9.80665 / 4.0, rel=1e-3)
    ramp = float(cmd.params.get("MPC_TKO_RAMP_T"))
    out = cmd.update(nav(0.1 + ramp / 2))
    assert out.velocity_ff_m_s[2] == pytest.approx((9.80665 / 4.0 - 1.5) / 2, rel=1e-3)
    out = cmd.update(nav(0.1 + ramp))
    assert out.velocity_ff_m_s[2] == pytest.approx(-1.5, rel=1e-3)
    out = cmd.update(nav(0.2 + ramp, z=-1.0, vz=-1.0, thrust=0.3))
    assert cmd.in_air and out.smooth
    assert out.position_ned_m[2] == pytest.approx(-2.5)


def test_disarm_in_air_denied_but_kill_works(cmd):
    cmd.arm(False)
    cmd.takeoff(None)
    cmd.update(nav(1.0, z=-1.0, vz=-1.0, thrust=0.3))
    assert cmd.in_air
    assert cmd.disarm(False) == DENIED and cmd.armed
    assert cmd.disarm(True) == ACCEPTED and not cmd.armed and cmd.killed


def test_flight_termination_disarms_and_is_reported_until_armed_again(cmd):
    """PX4's HEARTBEAT says MAV_STATE_FLIGHT_TERMINATION after a termination; a kill does not."""
    cmd.arm(False)
    cmd.takeoff(None)
    cmd.update(nav(1.0, z=-1.0, vz=-1.0, thrust=0.3))
    assert system_status(cmd) == mavlink2.MAV_STATE_ACTIVE
    assert cmd.terminate() == ACCEPTED and not cmd.armed and cmd.terminated
    assert system_status(cmd) == mavlink2.MAV_STATE_FLIGHT_TERMINATION
    assert cmd.arm(False) == ACCEPTED and not cmd.terminated
    assert cmd.disarm(True) == ACCEPTED and not cmd.terminated
    assert system_status(cmd) == mavlink2.MAV_STATE_STANDBY


def test_land_detection_then_auto_disarm_after_com_disarm_land(cmd):
    cmd.arm(False)
    cmd.takeoff(None)
    cmd.update(nav(1.0, z=-2.5, vz=0.0, thrust=0.23))
    assert cmd.land() == ACCEPTED
    t = 1.0
    while cmd.landed_state != LandedState.ON_GROUND and t < 10:
        t += 0.02
        cmd.update(nav(t, z=0.0, vz=0.0, thrust=0.05))
    assert cmd.landed_state == LandedState.ON_GROUND
    landed_at = t
    while cmd.armed and t < 20:
        t += 0.02
        cmd.update(nav(t, z=0.0, thrust=0.0))
    assert not cmd.armed
    assert t - landed_at == pytest.approx(2.0, abs=0.05)  # COM_DISARM_LAND


def test_unavailable_modes_are_denied(cmd):
    assert cmd.set_mode(MainMode.OFFBOARD, 0) == DENIED
    assert cmd.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == TEMPORARILY_REJECTED  # no mission
    assert cmd.set_mode(MainMode.POSCTL, 0) == DENIED
    assert cmd.set_mode(99, 0) == DENIED
    assert cmd.set_mode(MainMode.AUTO, AutoSubMode.LOITER) == ACCEPTED


def test_preflight_auto_disarm(cmd):
    cmd.arm(False)
    t = 0.0
    while cmd.armed and t < 30:
        t += 0.1
        cmd.update(nav(t))
    assert not cmd.armed
    assert t == pytest.approx(10.0, abs=0.15)  # COM_DISARM_PRFLT


# -- regressions: arming never takes off; take-off altitude clamped ------------------------------

ORIGIN_LAT_LON = (47.397742, 8.545594)
"""NED origin of the mission tests (origin altitude 488 m AMSL, as ``nav``)."""


def geo_nav(t, z=0.0, vz=0.0, thrust=0.0, north=0.0):
    """Like ``nav`` but with a geodetic origin, which missions and fences need."""
    return NavInput(
        t,
        np.array([north, 0.0, z]),
        np.array([0.0, 0.0, vz]),
        0.0,
        True,
        thrust,
        488.0,
        origin_lat_lon_deg=ORIGIN_LAT_LON,
    )


def texts(c):
    return [text for _, text in c.status_texts]


@pytest.mark.parametrize("ticks_before_kill", [0, 5])
def test_kill_during_takeoff_on_the_ground_leaves_it_landed_and_rearming_does_not_take_off(
    cmd, ticks_before_kill
):
    """arm + takeoff + kill before leaving the ground: ON_GROUND (MAVSDK in_air False), and a
    plain arm afterwards holds on the ground with idle motors instead of resuming the take-off."""
    t = 0.0
    assert cmd.arm(False) == ACCEPTED
    assert cmd.takeoff(None) == ACCEPTED
    for _ in range(ticks_before_kill):
        t += 0.02
        assert cmd.update(nav(t, thrust=0.2)).active  # spinning up, still on the ground
    assert cmd.disarm(True) == ACCEPTED
    assert cmd.landed_state == LandedState.ON_GROUND and not cmd.in_air
    t += 0.02
    cmd.update(nav(t))
    assert cmd.landed_state == LandedState.ON_GROUND
    assert cmd.arm(False) == ACCEPTED
    assert (cmd.main_mode, cmd.sub_mode) == (MainMode.AUTO, AutoSubMode.LOITER)  # Hold
    for _ in range(250):  # 5 s at 50 Hz
        t += 0.02
        out = cmd.update(nav(t))
        assert not out.active
        assert cmd.landed_state == LandedState.ON_GROUND
    assert cmd.armed and cmd.sub_mode == AutoSubMode.LOITER


def takeoff_target_z(c, alt_amsl_m, t=0.1):
    """The take-off target (the output ramps the climb rate until lift-off)."""
    assert c.takeoff(alt_amsl_m) == ACCEPTED
    c.update(nav(t))
    return float(c._target[2])


@pytest.mark.parametrize("alt_amsl_m", [488.0, 488.5, 490.0, 400.0, -1000.0])
def test_takeoff_below_or_near_the_ground_is_clamped_to_mis_takeoff_alt(cmd, alt_amsl_m):
    """Home at 488 m AMSL, MIS_TAKEOFF_ALT 2.5 m: any target under 490.5 m becomes 490.5 m."""
    cmd.arm(False)
    assert takeoff_target_z(cmd, alt_amsl_m) == pytest.approx(-2.5)
    assert any(t.startswith("Using minimum takeoff altitude") for t in texts(cmd))
    assert cmd.sub_mode == AutoSubMode.TAKEOFF


def test_takeoff_above_the_minimum_is_kept(cmd):
    cmd.arm(False)
    assert takeoff_target_z(cmd, 500.0) == pytest.approx(-12.0)
    assert not any(t.startswith("Using minimum takeoff altitude") for t in texts(cmd))


@pytest.mark.parametrize("alt_amsl_m", [None, math.nan])
def test_takeoff_without_altitude_uses_home_plus_mis_takeoff_alt(cmd, alt_amsl_m):
    cmd.arm(False)
    assert takeoff_target_z(cmd, alt_amsl_m) == pytest.approx(-2.5)


@pytest.mark.parametrize("alt_amsl_m", [None, 488.0, 488.3])
def test_mis_takeoff_alt_zero_still_climbs_min_takeoff_height(alt_amsl_m):
    c = Commander(ParamStore({"MIS_TAKEOFF_ALT": 0.0}))
    c.update(nav(0.0))
    c.arm(False)
    assert takeoff_target_z(c, alt_amsl_m) == pytest.approx(-MIN_TAKEOFF_HEIGHT_M)
    assert MIN_TAKEOFF_HEIGHT_M > 0.5  # above the land detector's take-off threshold


def test_takeoff_to_mis_takeoff_alt_leaves_the_ground_and_completes(cmd):
    """With the clamp, the climb reaches the land detector's threshold and the target."""
    cmd.arm(False)
    target = takeoff_target_z(cmd, 488.2)
    t, z = 0.1, 0.0
    while cmd.sub_mode == AutoSubMode.TAKEOFF and t < 10.0:
        t += 0.02
        z = max(target, z - 1.0 * 0.02)  # climbs at 1 m/s
        cmd.update(nav(t, z=z, vz=-1.0 if z > target else 0.0, thrust=0.3))
    assert cmd.landed_state == LandedState.IN_AIR
    assert cmd.sub_mode == AutoSubMode.LOITER
    assert "Takeoff complete, holding" in texts(cmd)


def hovering_at_20_m():
    c = Commander(ParamStore())
    c.update(nav(0.0))
    c.arm(False)
    c.takeoff(508.0)
    c.update(nav(1.0, z=-1.0, vz=-1.0, thrust=0.3))
    c.update(nav(2.0, z=-20.0, thrust=0.25))
    assert c.landed_state == LandedState.IN_AIR
    return c


def test_takeoff_in_the_air_to_a_lower_altitude_keeps_the_current_one():
    c = hovering_at_20_m()
    assert c.takeoff(495.0) == ACCEPTED
    assert float(c.update(nav(2.1, z=-20.0, thrust=0.25)).position_ned_m[2]) == pytest.approx(-20.0)
    assert "Already higher than takeoff altitude" in texts(c)


@pytest.mark.parametrize("alt_amsl_m", [None, math.nan])
def test_takeoff_without_altitude_in_the_air_does_not_descend(alt_amsl_m):
    c = hovering_at_20_m()
    assert c.takeoff(alt_amsl_m) == ACCEPTED
    out = c.update(nav(2.1, z=-20.0, thrust=0.25))
    assert float(out.position_ned_m[2]) == pytest.approx(-20.0)


# -- Mission mode and the mission's feasibility --------------------------------------------------


def mission_item(north_m, alt_m=10.0, command=mavlink2.MAV_CMD_NAV_WAYPOINT):
    """A waypoint north_m north of the origin, alt_m above home (111195 m per degree)."""
    lat = ORIGIN_LAT_LON[0] + north_m / 111195.0
    return MissionItem(
        command,
        mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        (0.0, 0.0, 0.0, math.nan),
        round(lat * 1e7),
        round(ORIGIN_LAT_LON[1] * 1e7),
        alt_m,
    )


def square_fence(half_side_m):
    """An inclusion polygon: a square of side 2 * half_side_m centred on the origin."""
    lat0, lon0 = ORIGIN_LAT_LON
    dlat = half_side_m / 111195.0
    dlon = dlat / math.cos(math.radians(lat0))
    corners = [(-dlat, -dlon), (-dlat, dlon), (dlat, dlon), (dlat, -dlon)]
    return tuple(
        MissionItem(
            mavlink2.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            mavlink2.MAV_FRAME_GLOBAL_INT,
            (4.0, 0.0, 0.0, 0.0),
            round((lat0 + a) * 1e7),
            round((lon0 + b) * 1e7),
            0.0,
        )
        for a, b in corners
    )


@pytest.fixture
def geo_cmd():
    c = Commander(ParamStore())
    c.update(geo_nav(0.0))
    assert c.home is not None
    return c


def test_mission_mode_needs_a_valid_mission(geo_cmd):
    c = geo_cmd
    assert c.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == TEMPORARILY_REJECTED
    assert c.sub_mode != AutoSubMode.MISSION
    mission = (mission_item(20.0), mission_item(40.0))
    assert c.upload_mission(MissionType.MISSION, mission) == 0
    assert c.mission_status() == (0, 2, MissionState.NOT_STARTED)
    assert c.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == ACCEPTED
    assert (c.main_mode, c.sub_mode) == (MainMode.AUTO, AutoSubMode.MISSION)


def test_mission_mode_armed_on_the_ground_climbs_to_the_first_item_height(geo_cmd):
    c = geo_cmd
    c.upload_mission(MissionType.MISSION, (mission_item(20.0, alt_m=8.0),))
    assert c.arm(False) == ACCEPTED
    assert c.sub_mode == AutoSubMode.LOITER  # arming alone stays on the ground
    assert c.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == ACCEPTED
    out = c.update(geo_nav(0.1))
    assert out.active
    assert c._target == pytest.approx([0.0, 0.0, -8.0])  # straight up first
    assert out.position_ned_m[:2] == pytest.approx([0.0, 0.0])  # (climb-rate ramp until lift-off)
    assert c.mission_status()[2] == MissionState.ACTIVE


@pytest.mark.parametrize("fence_first", [True, False])
def test_mission_outside_the_fence_is_stored_but_mission_mode_refused(geo_cmd, fence_first):
    """PX4 accepts the transfer, marks the mission invalid and says why."""
    c = geo_cmd
    mission = (mission_item(10.0), mission_item(100.0))
    uploads = [(MissionType.FENCE, square_fence(20.0)), (MissionType.MISSION, mission)]
    for kind, items in uploads if fence_first else uploads[::-1]:
        assert c.upload_mission(kind, items) == 0
    assert c.missions.items(MissionType.MISSION) == mission
    assert c.mission_status() == (0, 0xFFFF, MissionState.NO_MISSION)
    assert "Geofence violation for waypoint 2" in texts(c)
    assert c.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == TEMPORARILY_REJECTED
    assert c.upload_mission(MissionType.FENCE, ()) == 0  # fence cleared: the mission is valid
    assert c.set_mode(MainMode.AUTO, AutoSubMode.MISSION) == ACCEPTED


def test_leaving_land_mode_in_the_air_reports_in_air_again():
    """Found by the protocol fuzz: Hold after Land kept reporting LANDING while hovering."""
    c = hovering_at_20_m()
    assert c.land() == ACCEPTED
    c.update(nav(2.1, z=-19.9, vz=0.5, thrust=0.2))
    assert c.landed_state == LandedState.LANDING
    assert c.set_mode(MainMode.AUTO, AutoSubMode.LOITER) == ACCEPTED
    c.update(nav(2.2, z=-19.9, vz=0.0, thrust=0.25))
    assert c.landed_state == LandedState.IN_AIR
    assert c.takeoff(None) == ACCEPTED and c.in_air


def test_hold_at_speed_aims_at_the_braking_point():
    """Hold while flying 4 m/s north: target v²/(2 MPC_ACC_HOR) + 0.6 s x v ahead (PX4's jerk
    delay), not where it was."""
    c = hovering_at_20_m()
    moving = NavInput(50.0, np.array([10.0, 0.0, -20.0]), np.array([4.0, 0.0, 0.0]), 0.0, True,
                      0.23, 488.0)  # fmt: skip
    c.update(moving)
    assert c.set_mode(MainMode.AUTO, AutoSubMode.LOITER) == 0
    out = c.update(moving)
    acc = float(c.params.get("MPC_ACC_HOR"))
    assert out.position_ned_m[:2] == pytest.approx([10.0 + 16.0 / (2 * acc) + 0.6 * 4.0, 0.0])
    assert out.position_ned_m[2] == pytest.approx(-20.0)
