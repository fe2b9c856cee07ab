"""Offboard setpoints: frames, stream freshness, the loss action, and what one tick asks for."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot_emu.failsafe import Action
from autopilot_emu.modes.offboard import (
    LocalFrame,
    OffboardControl,
    OffboardSetpoint,
    loss_action,
    to_local_ned,
)

NAN3 = np.full(3, np.nan)


def velocity(vn: float, ve: float, vd: float, **kw) -> OffboardSetpoint:
    return OffboardSetpoint(velocity_ned_m_s=np.array([vn, ve, vd]), **kw)


def test_local_ned_is_taken_as_is():
    sp = OffboardSetpoint(position_ned_m=np.array([1.0, 2.0, -3.0]))
    assert to_local_ned(sp, LocalFrame.LOCAL_NED, np.array([5.0, 5.0, -5.0]), 1.0) is sp


def test_local_offset_adds_the_current_position():
    sp = OffboardSetpoint(position_ned_m=np.array([1.0, np.nan, -2.0]))
    out = to_local_ned(sp, LocalFrame.LOCAL_OFFSET_NED, np.array([10.0, 20.0, -5.0]), 0.7)
    assert out.position_ned_m[0] == pytest.approx(11.0)
    assert math.isnan(out.position_ned_m[1])
    assert out.position_ned_m[2] == pytest.approx(-7.0)


@pytest.mark.parametrize("frame", [LocalFrame.BODY_NED, LocalFrame.BODY_OFFSET_NED])
def test_body_velocity_turns_with_the_heading(frame):
    """Forward at heading east is east; right at heading east is south; down stays down."""
    east = math.pi / 2
    fwd = to_local_ned(velocity(2.0, 0.0, 0.5), frame, np.zeros(3), east).velocity_ned_m_s
    assert fwd == pytest.approx([0.0, 2.0, 0.5], abs=1e-9)
    right = to_local_ned(velocity(0.0, 1.0, 0.0), frame, np.zeros(3), east).velocity_ned_m_s
    assert right == pytest.approx([-1.0, 0.0, 0.0], abs=1e-9)


def test_body_position_is_an_offset_along_the_heading():
    sp = OffboardSetpoint(position_ned_m=np.array([3.0, 0.0, 0.0]), yaw_rad=0.3)
    out = to_local_ned(sp, LocalFrame.BODY_NED, np.array([1.0, 1.0, -4.0]), math.pi)
    assert out.position_ned_m == pytest.approx([-2.0, 1.0, -4.0], abs=1e-9)
    assert out.yaw_rad == 0.3  # yaw stays absolute


def test_single_horizontal_body_axis_has_no_meaning_once_rotated():
    sp = OffboardSetpoint(velocity_ned_m_s=np.array([1.0, np.nan, 0.0]))
    out = to_local_ned(sp, LocalFrame.BODY_NED, np.zeros(3), 0.5).velocity_ned_m_s
    assert np.isnan(out[:2]).all() and out[2] == 0.0


@pytest.mark.parametrize(
    ("value", "action"),
    [
        (0, Action.RTL),  # position mode needs manual control: PX4 falls back to Return
        (1, Action.RTL),
        (2, Action.RTL),
        (3, Action.RTL),
        (4, Action.LAND),
        (5, Action.HOLD),
        (6, Action.TERMINATE),
        (7, Action.DISARM),
        (42, Action.RTL),
    ],
)
def test_loss_action_follows_com_obl_rc_act(value, action):
    assert loss_action(value) == action


def test_stream_is_fresh_for_the_timeout_only():
    ctl = OffboardControl()
    assert not ctl.fresh(0.0, 1.0)
    ctl.receive(velocity(0, 0, 0), 10.0)
    assert ctl.fresh(10.9, 1.0)
    assert not ctl.fresh(11.1, 1.0)


def test_thrust_alone_updates_an_attitude_setpoint_and_nothing_else():
    ctl = OffboardControl()
    thrust_only = OffboardSetpoint(thrust=0.4)
    assert thrust_only.thrust_only
    assert not ctl.receive(thrust_only, 1.0)  # nothing to apply it to
    q = np.array([1.0, 0.0, 0.0, 0.0])
    assert ctl.receive(OffboardSetpoint(attitude_wxyz=q, thrust=0.3), 2.0)
    assert ctl.receive(thrust_only, 3.0)
    target = ctl.target(np.zeros(3), 0.0, 0.02, hover_thrust=0.25)
    assert target.thrust == 0.4 and target.attitude_wxyz is q
    assert ctl.received_s == 3.0


def test_attitude_without_thrust_starts_at_hover():
    ctl = OffboardControl()
    ctl.receive(OffboardSetpoint(attitude_wxyz=np.array([1.0, 0, 0, 0])), 0.0)
    assert ctl.target(np.zeros(3), 0.0, 0.02, hover_thrust=0.23).thrust == 0.23


def test_yaw_rate_turns_the_held_heading():
    ctl = OffboardControl()
    ctl.receive(velocity(0, 0, 0, yaw_rate_rad_s=0.5), 0.0)
    yaw = [ctl.target(np.zeros(3), 1.0, 0.1, 0.25).yaw_rad for _ in range(10)]
    assert yaw[0] == pytest.approx(1.05)
    assert yaw[-1] == pytest.approx(1.5)


def test_yaw_is_held_without_yaw_or_rate():
    ctl = OffboardControl()
    ctl.receive(velocity(1, 0, 0), 0.0)
    first = ctl.target(np.zeros(3), 0.8, 0.02, 0.25).yaw_rad
    later = ctl.target(np.zeros(3), 1.5, 0.02, 0.25).yaw_rad  # the vehicle drifted: keep 0.8
    assert first == later == pytest.approx(0.8)


def test_axes_without_anything_hold_and_acceleration_only_axes_are_marked():
    ctl = OffboardControl()
    sp = OffboardSetpoint(
        position_ned_m=np.array([np.nan, np.nan, -5.0]),
        acceleration_ned_m_s2=np.array([1.0, np.nan, np.nan]),
    )
    ctl.receive(sp, 0.0)
    target = ctl.target(np.array([3.0, 4.0, -1.0]), 0.0, 0.02, 0.25)
    # North: acceleration only (position and velocity NaN); east: nothing, held at 4 m.
    assert math.isnan(target.position_ned_m[0]) and math.isnan(target.velocity_ff_m_s[0])
    assert target.acceleration_ff_m_s2[0] == 1.0
    assert target.position_ned_m[1] == 4.0 and target.velocity_ff_m_s[1] == 0.0
    assert target.position_ned_m[2] == -5.0


@pytest.mark.parametrize(
    ("setpoint", "climbs"),
    [
        (OffboardSetpoint(position_ned_m=np.array([0.0, 0.0, -5.0])), True),
        (OffboardSetpoint(position_ned_m=np.array([0.0, 0.0, -0.1])), False),
        (velocity(0, 0, -1.0), True),
        (velocity(2.0, 0, 0.0), False),
        (OffboardSetpoint(acceleration_ned_m_s2=np.array([0, 0, -2.0])), True),
        (OffboardSetpoint(attitude_wxyz=np.array([1.0, 0, 0, 0]), thrust=0.6), True),
        (OffboardSetpoint(attitude_wxyz=np.array([1.0, 0, 0, 0]), thrust=0.1), False),
    ],
)
def test_takeoff_starts_when_the_setpoint_lifts_the_vehicle(setpoint, climbs):
    ctl = OffboardControl()
    ctl.receive(setpoint, 0.0)
    assert ctl.wants_climb(np.zeros(3), hover_thrust=0.25) is climbs


def test_needs_position_only_for_position_velocity_and_acceleration():
    assert velocity(1, 0, 0).needs_position
    assert not OffboardSetpoint(attitude_wxyz=np.array([1.0, 0, 0, 0]), thrust=0.5).needs_position
    assert not OffboardSetpoint(body_rates_rad_s=np.zeros(3), thrust=0.5).needs_position
