"""The swarm engine's point-mass vehicles: limits honoured, paths flown, landing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.kinematic_fleet import KinematicFleet
from sitl.vehicles.kinematics import KinematicLimits, load_kinematic_limits

LIMITS = KinematicLimits(
    max_speed_m_s=12.0,
    max_accel_m_s2=3.0,
    max_turn_rate_deg_s=45.0,
    max_climb_m_s=3.0,
    max_descent_m_s=1.5,
    max_vertical_accel_m_s2=4.0,
)
DT = 0.1


def fly(fleet: KinematicFleet, seconds: float) -> list[np.ndarray]:
    """Step ``seconds``; return the positions after each step."""
    out = []
    for _ in range(round(seconds / DT)):
        fleet.step(DT)
        out.append(fleet.state.position_m.copy())
    return out


def airborne_fleet(n: int = 1, height_m: float = 10.0) -> KinematicFleet:
    fleet = KinematicFleet(np.column_stack((np.arange(n) * 5.0, np.zeros(n), np.zeros(n))), LIMITS)
    for i in range(n):
        fleet.takeoff(i, height_m)
    fly(fleet, 20.0)
    assert fleet.path_done().all()
    return fleet


def test_takeoff_climbs_within_the_climb_rate_and_stops_at_the_height() -> None:
    fleet = KinematicFleet(np.zeros((1, 3)), LIMITS)
    fleet.takeoff(0, 10.0, climb_m_s=2.0)
    heights = np.array([p[0, 2] for p in fly(fleet, 15.0)])
    rates = np.diff(heights) / DT
    assert rates.max() <= 2.0 + 1e-9
    assert heights[-1] == pytest.approx(10.0, abs=0.01)
    assert heights.max() <= 10.0 + 1e-9
    assert fleet.state.airborne[0]


def test_cruise_respects_speed_and_acceleration_limits() -> None:
    fleet = airborne_fleet()
    fleet.set_path(0, np.array([[500.0, 0.0, 10.0]]), cruise_m_s=20.0)  # asks for more than max
    track = np.array([p[0] for p in fly(fleet, 60.0)])
    speeds = np.linalg.norm(np.diff(track[:, :2], axis=0), axis=1) / DT
    assert speeds.max() <= LIMITS.max_speed_m_s + 1e-9
    assert speeds.max() == pytest.approx(LIMITS.max_speed_m_s, rel=1e-6)
    accel = np.abs(np.diff(speeds)) / DT
    # braking too: the stop on the point is within 20 % of the limit over its last step
    assert accel.max() <= 1.2 * LIMITS.max_accel_m_s2
    # reaches the end in about distance / speed plus the acceleration ramps, and stops there
    assert fleet.path_done()[0]
    assert np.hypot(*(fleet.state.position_m[0, :2] - [500.0, 0.0])) < fleet.acceptance_m
    assert fleet.state.speed_m_s[0] < 0.5


def test_turns_are_rate_limited_and_waypoints_are_passed_in_order() -> None:
    fleet = airborne_fleet()
    square = np.array([[60.0, 0, 10], [60, 60, 10], [0, 60, 10], [0, 0, 10]], dtype=float)
    fleet.set_path(0, square, cruise_m_s=8.0)
    passed: list[int] = []
    courses = []
    for _ in range(round(120 / DT)):
        fleet.step(DT)
        courses.append((fleet.state.course_rad[0], fleet.state.speed_m_s[0]))
        if not passed or fleet.index[0] != passed[-1]:
            passed.append(int(fleet.index[0]))
    assert passed == [0, 1, 2, 3]
    assert fleet.path_done()[0]
    c = np.array(courses)
    moving = c[1:, 1] > 1.0  # above hover speed the course turns at most the limit
    turn = np.abs((np.diff(c[:, 0]) + np.pi) % (2 * np.pi) - np.pi) / DT
    assert turn[moving].max() <= math.radians(LIMITS.max_turn_rate_deg_s) + 1e-9


def test_landing_touches_down_and_counts_airborne_time_and_distance() -> None:
    fleet = airborne_fleet(n=3)
    fleet.land(1)
    fly(fleet, 20.0)
    assert list(fleet.state.airborne) == [True, False, True]
    assert fleet.state.position_m[1, 2] == pytest.approx(0.0)
    assert fleet.airborne_s[1] < fleet.airborne_s[0]
    assert fleet.distance_m[1] == pytest.approx(20.0, abs=0.1)  # up 10 m and down 10 m


def test_vehicles_are_independent_and_the_model_is_deterministic() -> None:
    def run() -> np.ndarray:
        fleet = airborne_fleet(n=2)
        fleet.set_path(0, np.array([[100.0, 50.0, 10.0]]), 10.0)
        fly(fleet, 30.0)
        return fleet.state.position_m.copy()

    a, b = run(), run()
    assert np.array_equal(a, b)
    assert np.allclose(a[1], [5.0, 0.0, 10.0])  # vehicle 1 holds where it climbed


def test_bad_paths_and_limits_are_refused() -> None:
    fleet = KinematicFleet(np.zeros((2, 3)), LIMITS)
    with pytest.raises(ValueError, match="finite waypoints"):
        fleet.set_path(0, np.array([[np.nan, 0.0, 1.0]]))
    with pytest.raises(ValueError, match="one per vehicle"):
        KinematicFleet(np.zeros((2, 3)), [LIMITS])
    with pytest.raises(ValueError, match="max_speed_m_s"):
        KinematicLimits(0.0, 3.0, 45.0, 3.0, 1.5, 4.0)


def test_airframes_carry_kinematic_limits_and_a_broken_section_is_named(tmp_path) -> None:
    assert load_kinematic_limits("typhoon_h480").max_speed_m_s == 12.0
    assert load_kinematic_limits("x500").max_accel_m_s2 == 3.0
    folder = tmp_path / "frame"
    folder.mkdir()
    (folder / "frame.yaml").write_text("kinematics: {max_speed_m_s: 3}\n")
    with pytest.raises(ValueError, match=r"missing keys \['max_accel_m_s2'"):
        load_kinematic_limits(folder)
    (folder / "frame.yaml").write_text("description: none\n")
    with pytest.raises(ValueError, match="no 'kinematics' section"):
        load_kinematic_limits(folder)
