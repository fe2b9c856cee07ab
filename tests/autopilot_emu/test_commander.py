"""Commander state machine: PX4's arming rules, mode switching and land detection."""

import numpy as np
import pytest

from autopilot_emu.commander import ACCEPTED, DENIED, TEMPORARILY_REJECTED, Commander, NavInput
from autopilot_emu.modes import AutoSubMode, LandedState, MainMode
from autopilot_emu.params import ParamStore


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
    assert out.position_ned_m[2] == pytest.approx(-2.5)  # MIS_TAKEOFF_ALT default


def test_disarm_in_air_denied_but_kill_works(cmd):
    cmd.arm(False)
    cmd.takeoff(None)
    cmd.update(nav(1.0, z=-1.0, vz=-1.0, thrust=0.3))
    assert cmd.in_air
    assert cmd.disarm(False) == DENIED and cmd.armed
    assert cmd.disarm(True) == ACCEPTED and not cmd.armed and cmd.killed


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
