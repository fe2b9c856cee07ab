"""The auto-mode trajectory respects its speed, acceleration and jerk limits and stops on target.

The trajectory is stepped by the navigation loop the fleet flies (``NavLoop.step`` with the
commander asking for smoothing), the vehicle kept on the trajectory unless said otherwise.
"""

import subprocess
import sys

import numpy as np
import pytest
from nav_support import DT, Nav

from autopilot_emu.control.trajectory import braking_distance, hold_point

pytestmark = pytest.mark.process


class Smoothed(Nav):
    """A NavLoop whose vehicles all track their trajectory towards ``target`` (N, 3)."""

    def __init__(self, target, cruise=5.0, up=3.0, down=1.5, acc=3.0, jerk=4.0, err=2.0):
        n = len(target)
        super().__init__(n, acc_hor_max_m_s2=acc, jerk_m_s3=jerk, error_max_m=err)
        self.sp.position_ned_m[:] = target
        self.sp.max_speed_xy_m_s[:] = cruise
        self.sp.max_speed_up_m_s[:] = up
        self.sp.max_speed_down_m_s[:] = down
        self.smooth[:] = True
        self.state.smoothing[:] = True  # a trajectory under way: its state is as set

    def tick(self, vehicle=None):
        """One step with the vehicle at ``vehicle`` (default: on the trajectory)."""
        s = self.state
        self.position[:] = s.trajectory_position_m if vehicle is None else vehicle
        self.run()
        return tuple(
            a.copy()
            for a in (
                s.trajectory_position_m,
                s.trajectory_velocity_m_s,
                s.trajectory_acceleration_m_s2,
            )
        )


def _fly(target, seconds, start=None, vehicle=None, velocity=None, acceleration=None, **limits):
    """Position, velocity and acceleration logs of trajectories from ``start`` (and
    ``velocity``, ``acceleration``: default at rest) towards ``target``."""
    nav = Smoothed(target, **limits)
    s = nav.state
    for state, value in (
        (s.trajectory_position_m, start),
        (s.trajectory_velocity_m_s, velocity),
        (s.trajectory_acceleration_m_s2, acceleration),
    ):
        if value is not None:
            state[:] = value
    log = [nav.tick(vehicle) for _ in range(int(seconds / DT))]
    return [np.array(x) for x in zip(*log, strict=True)]


def test_a_vehicle_that_starts_smoothing_starts_the_trajectory_where_it_is():
    """From the vehicle's position and velocity, at rest in acceleration: no jump."""
    nav = Smoothed(np.array([[50.0, 1.0, -5.0]]))
    nav.state.smoothing[:] = False
    nav.state.trajectory_acceleration_m_s2[:] = 9.0  # stale
    nav.velocity[0] = [2.0, 0.0, 0.0]
    pos, vel, acc = nav.tick(vehicle=np.array([[3.0, 1.0, -5.0]]))
    np.testing.assert_allclose(pos[0], [3.0 + 2.0 * DT, 1.0, -5.0], atol=1e-3)
    np.testing.assert_allclose(vel[0, 1:], 0.0, atol=1e-9)
    assert abs(vel[0, 0] - 2.0) < 0.1 and np.abs(acc[0]).max() <= 4.0 * DT + 1e-12


@pytest.mark.parametrize("cruise", [5.0, 10.0])
def test_long_leg_cruises_at_the_limit_and_stops_on_target_without_overshoot(cruise):
    target = np.array([[80.0, 0.0, 0.0], [0.0, -80.0, 0.0]])
    pos, vel, acc = _fly(target, 40.0, cruise=cruise)
    speed = np.hypot(vel[..., 0], vel[..., 1])
    assert speed.max() == pytest.approx(cruise, rel=1e-3)
    along = np.stack((pos[:, 0, 0], -pos[:, 1, 1]), axis=1)
    assert along.max() <= 80.0 + 1e-3  # no overshoot
    np.testing.assert_allclose(pos[-1], target, atol=0.01)
    assert np.abs(pos[:, 0, 1]).max() < 1e-9  # straight line
    assert np.hypot(acc[..., 0], acc[..., 1]).max() <= 3.0 + 1e-9
    jerk = np.diff(acc, axis=0) / DT
    assert np.linalg.norm(jerk, axis=2).max() <= 4.0 + 1e-6


def test_vertical_limits_are_asymmetric():
    target = np.array([[0.0, 0.0, -30.0], [0.0, 0.0, 30.0]])
    pos, vel, acc = _fly(target, 40.0, up=3.0, down=1.5)
    assert vel[:, 0, 2].min() == pytest.approx(-3.0, rel=1e-3)
    assert vel[:, 1, 2].max() == pytest.approx(1.5, rel=1e-3)
    assert acc[:, 0, 2].min() >= -4.0 - 1e-9  # MPC_ACC_UP_MAX
    assert acc[:, :, 2].max() <= 3.0 + 1e-9  # MPC_ACC_DOWN_MAX
    assert pos[:, 0, 2].min() >= -30.0 - 1e-3 and pos[:, 1, 2].max() <= 30.0 + 1e-3


def test_short_hop_never_overshoots():
    target = np.array([[1.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    pos, _, _ = _fly(target, 20.0, cruise=12.0)
    assert pos[:, 0, 0].max() <= 1.0 + 1e-3 and pos[:, 1, 0].max() <= 3.0 + 1e-3
    np.testing.assert_allclose(pos[-1], target, atol=0.01)


def test_trajectory_waits_for_a_vehicle_that_lags_behind():
    """MPC_XY_ERR_MAX: with the vehicle stuck at the start, the trajectory stops 2 m ahead."""
    target = np.array([[50.0, 0.0, 0.0]])
    pos, _, _ = _fly(target, 20.0, vehicle=np.zeros((1, 3)), err=2.0)
    assert 1.0 < pos[-1, 0, 0] <= 2.0


def test_braking_distance_stops_a_cruising_trajectory():
    """A Hold target at the navigator's braking distance is overshot by less than 0.5 m."""
    nav = Smoothed(np.array([[1000.0, 0.0, 0.0]]), cruise=5.0)
    for _ in range(int(5.0 / DT)):
        nav.tick()
    s = nav.state
    assert s.trajectory_velocity_m_s[0, 0] == pytest.approx(5.0, rel=1e-3)
    stop = s.trajectory_position_m[0, 0] + braking_distance(5.0, 3.0, 4.0)
    nav.sp.position_ned_m[0] = [stop, 0.0, 0.0]
    peak = max(nav.tick()[0][0, 0] for _ in range(int(10.0 / DT)))
    assert peak <= stop + 0.5


def _run_to_rest(target_xy, pos, vel, acc, seconds=15.0):
    """North-east track of one trajectory from a state towards a horizontal target."""
    target = np.array([[target_xy[0], target_xy[1], pos[2]]])
    track, _, _ = _fly(target, seconds, start=pos[None], velocity=vel, acceleration=acc)
    return track[:, 0, :2]


@pytest.mark.parametrize("acc_now", [0.0, 1.5, 3.0])
@pytest.mark.parametrize("speed", [2.0, 5.0])
def test_hold_point_is_reached_without_turning_back(speed, acc_now):
    """From a state still speeding up, the hold point is reached, never passed by over 2 cm."""
    u = np.array([0.6, 0.8, 0.0])
    pos, vel, acc = np.array([3.0, -2.0, -5.0]), speed * u, acc_now * u
    target = hold_point(pos, vel, acc, 5.0, 3.0, 4.0, DT)
    track = _run_to_rest(target, pos, vel, acc)
    past = (track - target) @ u[:2]
    assert past.max() <= 0.02 + 1e-6
    assert np.hypot(*(track[-1] - target)) < 0.02
    # A target 0.3 m nearer is passed: the point is the nearest that is not.
    nearer = target - 0.3 * u[:2]
    assert ((_run_to_rest(nearer, pos, vel, acc) - nearer) @ u[:2]).max() > 0.05


def test_hold_point_grows_with_the_acceleration_still_building_speed():
    steady = hold_point(np.zeros(3), np.array([4.0, 0, 0]), np.zeros(3), 5.0, 3.0, 4.0, DT)
    rising = hold_point(np.zeros(3), np.array([4.0, 0, 0]), np.array([3.0, 0, 0]), 5.0, 3.0,
                        4.0, DT)  # fmt: skip
    assert steady[1] == pytest.approx(0.0) and rising[0] > steady[0] + 1.0


@pytest.mark.parametrize("speed", [2.0, 4.0, 5.0])
def test_hold_point_at_a_steady_speed_is_within_0_7_m_of_px4s_braking_point(speed):
    """Up to the default cruise speed, "no turning back" costs less than 0.7 m past PX4's point."""
    steady = hold_point(np.zeros(3), np.array([speed, 0, 0]), np.zeros(3), 5.0, 3.0, 4.0, DT)
    px4 = braking_distance(speed, 3.0, 4.0)
    assert px4 - 0.2 < steady[0] < px4 + 0.7


def test_hold_point_of_a_state_at_rest_is_where_it_is():
    here = np.array([1.0, 2.0, -3.0])
    assert hold_point(here, np.zeros(3), np.zeros(3), 5.0, 3.0, 4.0, DT) == pytest.approx(here[:2])


def test_a_new_fleet_has_the_hold_point_kernel_ready_before_the_first_hold():
    """Compiling it at the first Hold stood the flight still for seconds (a MAVSDK timeout)."""
    code = (
        "from autopilot_emu.control.trajectory_kernel import hold_point_kernel\n"
        "from autopilot_emu.fleet import AutopilotFleet, FleetConfig\n"
        "assert not hold_point_kernel.signatures\n"
        "AutopilotFleet(FleetConfig(n_vehicles=1))\n"
        "assert hold_point_kernel.signatures\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, timeout=600)
