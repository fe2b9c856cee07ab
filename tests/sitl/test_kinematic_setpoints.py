"""Velocity setpoints of the point-mass fleet: reached within the limits, held, left for a path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.kinematic_fleet import HOVER_SPEED_M_S, KinematicFleet
from sitl.vehicles.kinematics import KinematicLimits

LIMITS = KinematicLimits(12.0, 3.0, 45.0, 3.0, 1.5, 4.0)
DT = 0.05


def hovering() -> KinematicFleet:
    fleet = KinematicFleet(np.zeros((1, 3)), LIMITS)
    fleet.takeoff(0, 10.0)
    for _ in range(round(15 / DT)):
        fleet.step(DT)
    return fleet


def test_a_velocity_setpoint_is_reached_and_held_capped_by_the_limits():
    fleet = hovering()
    fleet.set_velocity(0, np.array([30.0, 0.0, 5.0]))  # above both the speed and climb limits
    speeds, climbs = [], []
    for _ in range(round(20 / DT)):
        fleet.step(DT)
        speeds.append(fleet.state.speed_m_s[0])
        climbs.append(fleet.state.climb_m_s[0])
    assert max(speeds) <= 12.0 + 1e-9 and speeds[-1] == pytest.approx(12.0)
    assert max(climbs) <= 3.0 + 1e-9 and climbs[-1] == pytest.approx(3.0)
    assert np.diff(speeds).max() <= 3.0 * DT + 1e-9  # the acceleration limit
    assert not fleet.path_done()[0]


def test_a_turned_velocity_setpoint_turns_no_faster_than_the_limits():
    fleet = hovering()
    fleet.set_velocity(0, np.array([6.0, 0.0, 0.0]))
    for _ in range(round(10 / DT)):
        fleet.step(DT)
    fleet.set_velocity(0, np.array([0.0, 6.0, 0.0]))
    courses, speeds = [fleet.state.course_rad[0]], [fleet.state.speed_m_s[0]]
    for _ in range(round(10 / DT)):
        fleet.step(DT)
        courses.append(fleet.state.course_rad[0])
        speeds.append(fleet.state.speed_m_s[0])
    rate = np.degrees(np.abs(np.diff(courses))) / DT
    moving = np.array(speeds[:-1]) >= HOVER_SPEED_M_S  # a hovering multicopter turns freely
    # min(turn rate, a / V): 45 deg/s, or less at speed
    cap = np.minimum(45.0, np.degrees(3.0 / np.maximum(speeds[:-1], 1e-9)))
    assert (rate[moving] <= cap[moving] + 1e-6).all()
    assert courses[-1] == pytest.approx(math.pi / 2, abs=1e-6)
    assert fleet.state.velocity_m_s[0] == pytest.approx([0.0, 6.0, 0.0], abs=1e-6)


def test_a_path_after_a_velocity_flies_the_path_as_before():
    fleet = hovering()
    fleet.set_velocity(0, np.array([3.0, 3.0, 0.0]))
    for _ in range(round(5 / DT)):
        fleet.step(DT)
    fleet.set_path(0, np.array([[0.0, 0.0, 10.0]]), 5.0)
    for _ in range(round(30 / DT)):
        fleet.step(DT)
    assert fleet.path_done()[0]
    assert fleet.state.position_m[0] == pytest.approx([0.0, 0.0, 10.0], abs=0.05)


def test_zero_velocity_stops_and_a_grounded_vehicle_stays_down():
    fleet = hovering()
    fleet.set_velocity(0, np.array([5.0, 0.0, 0.0]))
    for _ in range(round(5 / DT)):
        fleet.step(DT)
    fleet.set_velocity(0, np.zeros(3))
    for _ in range(round(5 / DT)):
        fleet.step(DT)
    assert fleet.state.velocity_m_s[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)
    grounded = KinematicFleet(np.zeros((1, 3)), LIMITS)
    grounded.set_velocity(0, np.array([5.0, 0.0, 1.0]))
    grounded.step(DT)
    assert grounded.state.position_m[0] == pytest.approx([0.0, 0.0, 0.0])
