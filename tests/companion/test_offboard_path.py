"""Flying a waypoint path with offboard velocity setpoints (``companion.offboard_path``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from companion.offboard_path import FollowParams, PathFollower

ACC_M_S2 = 3.0
"""The plant's horizontal and vertical acceleration limit (PX4's MPC_ACC_HOR default), m/s^2."""


def fly(
    follower: PathFollower, start: np.ndarray, duration_s: float, setpoint_hz: float = 10.0
) -> tuple[np.ndarray, list[float], list[int]]:
    """A point mass that follows the latest velocity setpoint within ACC_M_S2, 50 Hz.

    Returns the final position, the speeds and the waypoint index at each step.
    """
    dt = 0.02
    every = round(1.0 / setpoint_hz / dt)
    pos, vel = np.asarray(start, float).copy(), np.zeros(3)
    want = np.zeros(3)
    speeds, index = [], []
    for k in range(round(duration_s / dt)):
        follower.see(pos)
        if k % every == 0:
            want = follower.velocity(pos)
        dv = want - vel
        n = float(np.linalg.norm(dv))
        if n > ACC_M_S2 * dt:
            dv *= ACC_M_S2 * dt / n
        vel += dv
        pos += vel * dt
        speeds.append(float(np.linalg.norm(vel)))
        index.append(follower.index)
    return pos, speeds, index


def test_a_point_mass_flies_a_bent_path_through_every_waypoint_and_settles_on_the_last() -> None:
    """Through each waypoint in order (within the acceptance radius), at most the commanded
    speed (plus the cross-track correction's share), then at rest on the last one within 0.2 m;
    ``done`` only there."""
    path = np.array([[40.0, 0.0, 10.0], [40.0, 30.0, 12.0], [80.0, 60.0, 12.0]])
    start = np.array([0.0, 0.0, 10.0])
    follower = PathFollower(path, 6.0, start)
    assert not follower.done(start)
    end, speeds, index = fly(follower, start, 60.0)
    assert index == sorted(index) and set(index) == {0, 1, 2}
    assert math.dist(end, path[-1]) < 0.2 and speeds[-1] < 0.05
    assert follower.done(end)
    assert max(speeds) < 6.0 * 1.1
    assert max(speeds) > 5.5  # the long legs are flown at the commanded speed


def test_the_speed_before_a_sharp_corner_allows_the_turn_and_a_straight_one_keeps_it() -> None:
    """2 m before a right-angle corner the setpoint's speed along the leg is at most
    sqrt(2 a d) (a = brake_m_s2, d = 2 m); before a waypoint that continues straight on it is
    the full speed."""
    params = FollowParams()
    here = np.array([18.0, 0.0, 10.0])
    corner = PathFollower(np.array([[20.0, 0, 10], [20.0, 40, 10]]), 6.0, [0.0, 0, 10], params)
    v = corner.velocity(here)
    assert v[0] == pytest.approx(math.sqrt(2.0 * params.brake_m_s2 * 2.0))
    assert corner.index == 0  # 2 m is not within the acceptance radius
    straight = PathFollower(np.array([[20.0, 0, 10], [60.0, 0, 10]]), 6.0, [0.0, 0, 10], params)
    assert straight.velocity(here) == pytest.approx([6.0, 0.0, 0.0])


def test_off_the_leg_the_velocity_leads_back_onto_it() -> None:
    """1 m north of an eastward leg and 0.5 m low: ``gain`` times the way back, plus the speed
    along the leg."""
    follower = PathFollower(np.array([[100.0, 0, 10]]), 5.0, [0.0, 0, 10])
    v = follower.velocity(np.array([10.0, 1.0, 9.5]))
    assert v == pytest.approx([5.0, -1.0, 0.5])


def test_a_waypoint_is_passed_only_within_the_acceptance_radius_and_height_tolerance() -> None:
    """1.9 m away horizontally but 1.5 m high: not passed; the velocity then heads to it (abreast
    of it, nothing pushes on along the leg); within 1 m of its height: passed, from there."""
    path = np.array([[10.0, 0, 10], [10.0, 20, 10]])
    follower = PathFollower(path, 6.0, [0.0, 0, 10])
    high = np.array([10.0, 1.9, 11.5])
    follower.see(high)
    assert follower.index == 0
    assert follower.velocity(high) == pytest.approx(path[0] - high)
    follower.see([10.0, 1.9, 10.8])
    assert follower.index == 1


def test_parameters_and_paths_are_checked() -> None:
    with pytest.raises(ValueError, match="acceptance_m"):
        FollowParams(acceptance_m=0.0)
    with pytest.raises(ValueError, match="speed_m_s"):
        PathFollower(np.array([[1.0, 0, 0]]), 0.0, [0.0, 0, 0])
    with pytest.raises(ValueError, match="waypoint"):
        PathFollower(np.zeros((0, 3)), 1.0, [0.0, 0, 0])
