"""The fused navigation-rate kernel: trajectory smoothing, position control, offboard overrides."""

from __future__ import annotations

import numpy as np

from autopilot_emu.control.hover_thrust_kernel import G_M_S2, hover_thrust_tick_kernel
from autopilot_emu.control.nav_kernel import nav_kernel
from autopilot_emu.control.position import PositionSetpoint

DT = 0.02


class Nav:
    """Inputs and state of the nav kernel for n vehicles hovering at the origin."""

    def __init__(self, n=1):
        self.n = n
        self.sp = PositionSetpoint.hold(n)
        self.sp.position_ned_m[:] = 0.0
        f = lambda v: np.full(n, float(v))  # noqa: E731
        self.limits = [f(12.0), f(3.0), f(1.0), f(3.0), f(4.0), f(3.0), f(4.0), f(2.0)]
        self.traj = [np.zeros((n, 3)) for _ in range(3)]
        self.smooth = np.zeros(n, dtype=bool)
        self.smoothing = np.zeros(n, dtype=bool)
        t3 = lambda xyz: np.tile(xyz, (n, 1))  # noqa: E731
        self.gains_axes = np.stack(
            (t3([0.95, 0.95, 1.0]), t3([1.8, 1.8, 4.0]), t3([0.4, 0.4, 2.0]), t3([0.2, 0.2, 0.0]))
        )
        self.gains_vehicle = np.stack((f(np.radians(45.0)), f(np.cos(np.radians(45.0))), f(3.0)))
        self.hover = f(0.5)
        self.vel_int = np.zeros((n, 3))
        self.vel_sp = np.zeros((n, 3))
        self.prev_vel = np.zeros((n, 3))
        self.rate_integral = np.zeros((n, 3))
        self.position = np.zeros((n, 3))
        self.velocity = np.zeros((n, 3))
        self.active = np.ones(n, dtype=bool)
        self.att_q = np.full((n, 4), np.nan)
        self.att_thrust = np.full(n, np.nan)
        self.q_sp = np.zeros((n, 4))
        self.thrust = np.zeros(n)
        self.overridden = np.zeros(n, dtype=bool)

    def run(self):
        sp = self.sp
        nav_kernel(
            sp.position_ned_m, sp.velocity_ff_m_s, sp.yaw_rad, sp.max_speed_xy_m_s,
            sp.max_speed_up_m_s, sp.max_speed_down_m_s, sp.acceleration_ff_m_s2, sp.smoothed,
            np.stack(self.limits), *self.traj, self.smooth, self.smoothing, self.gains_axes,
            self.gains_vehicle, self.hover, self.vel_int, self.vel_sp, self.prev_vel,
            self.rate_integral, self.position, self.velocity, DT, self.active, self.att_q,
            self.att_thrust, self.q_sp, self.thrust, self.overridden,
        )  # fmt: skip


def test_hover_on_target_asks_for_hover_thrust_level():
    nav = Nav()
    nav.run()
    np.testing.assert_allclose(nav.q_sp[0], [1.0, 0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(nav.thrust[0], 0.5, atol=1e-12)


def test_nan_axes_switch_to_velocity_then_acceleration_control():
    """No position north: velocity control; neither position nor velocity east: the velocity
    setpoint follows the vehicle and the acceleration feed-forward alone tilts it."""
    nav = Nav()
    nav.sp.position_ned_m[0, :2] = np.nan
    nav.sp.velocity_ff_m_s[0, :2] = [1.0, np.nan]
    nav.sp.acceleration_ff_m_s2[0, 1] = 2.0
    nav.velocity[0] = [0.0, 0.7, 0.0]
    nav.sp.smoothed[:] = True  # no slew limit: the setpoint is taken as given
    nav.run()
    np.testing.assert_allclose(nav.vel_sp[0], [1.0, 0.7, 0.0], atol=1e-12)
    assert nav.vel_int[0, 1] == 0.0 and nav.vel_int[0, 0] > 0.0
    assert nav.q_sp[0, 1] > 0.0  # tilting east: rolling right


def test_inactive_vehicles_reset_their_controllers_and_get_no_thrust():
    nav = Nav(2)
    nav.vel_int[:] = 1.0
    nav.rate_integral[:] = 0.2
    nav.active[1] = False
    nav.velocity[1] = [1.0, 2.0, 3.0]
    nav.run()
    assert nav.thrust[1] == 0.0 and nav.thrust[0] > 0.0
    np.testing.assert_array_equal(nav.vel_int[1], 0.0)
    np.testing.assert_array_equal(nav.rate_integral[1], 0.0)
    np.testing.assert_array_equal(nav.vel_sp[1], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(nav.rate_integral[0], 0.2)


def test_offboard_attitude_and_thrust_replace_the_position_loop():
    nav = Nav(2)
    nav.vel_int[:] = 1.0
    nav.att_thrust[:] = [1.7, 0.3]
    nav.att_q[0] = [0.0, 1.0, 0.0, 0.0]  # vehicle 1: thrust only, the position loop's attitude
    nav.run()
    np.testing.assert_array_equal(nav.overridden, [True, True])
    np.testing.assert_array_equal(nav.q_sp[0], [0.0, 1.0, 0.0, 0.0])
    assert nav.q_sp[1, 0] > 0.99  # near level: the position loop's own attitude
    np.testing.assert_array_equal(nav.thrust, [1.0, 0.3])
    np.testing.assert_array_equal(nav.vel_int, 0.0)


def test_smoothing_starts_the_trajectory_at_the_vehicle_and_moves_towards_the_target():
    nav = Nav()
    nav.position[0] = [1.0, 2.0, -3.0]
    nav.velocity[0] = [0.5, 0.0, 0.0]
    nav.sp.position_ned_m[0] = [20.0, 2.0, -3.0]
    nav.smooth[0] = True
    nav.run()
    pos, vel, acc = nav.traj
    assert nav.smoothing[0]
    assert 1.0 < pos[0, 0] < 1.02 and acc[0, 0] > 0.0  # from the vehicle, accelerating north
    # The controller tracks the trajectory (velocity feed-forward, no slew limit), not the
    # far target: its velocity setpoint is the trajectory's velocity plus P x (tiny) error.
    np.testing.assert_allclose(nav.vel_sp[0, 0], vel[0, 0] + 0.95 * (pos[0, 0] - 1.0))


def test_hover_thrust_hand_over_keeps_the_thrust_continuous():
    """A valid estimate replaces the hover thrust in use; the vertical integrator absorbs the
    change so that hover * (g - integrator) (the thrust at zero velocity error) is unchanged."""
    n = 2
    f = lambda v: np.full(n, float(v))  # noqa: E731
    estimate, valid = f(0.3), np.array([True, False])
    learned, in_use = np.zeros(n, dtype=bool), f(0.5)
    vel_int = np.tile([0.0, 0.0, 1.0], (n, 1))
    armed = np.array([True, False])
    rotation = np.tile(np.eye(3), (n, 1, 1))
    before = in_use * (G_M_S2 - vel_int[:, 2])
    hover_thrust_tick_kernel(
        np.zeros(n, dtype=bool), armed, np.zeros((n, 3)), f(0.3), rotation, np.zeros((n, 3)),
        DT, f(0.5), f(0.0036), f(3.0), f(0.1), f(0.4), f(10.0), f(2.0), estimate, f(1e-4),
        f(5.0), f(0.0), f(0.0), valid, f(3.0), learned, in_use, vel_int,
    )  # fmt: skip
    # Vehicle 0 (armed, not flying): its valid flag is cleared by the update, but the last
    # valid value... was never taken: hover stays MPC_THR_HOVER; vehicle 1 disarmed resets.
    np.testing.assert_array_equal(in_use, [0.5, 0.5])
    np.testing.assert_array_equal(learned, [False, False])
    # Now a valid estimate in flight.
    estimate[:], valid[:] = 0.3, [True, False]
    variance, good_for = f(1e-5), np.array([3.0, 0.0])
    hover_thrust_tick_kernel(
        np.ones(n, dtype=bool), np.ones(n, dtype=bool), np.zeros((n, 3)), f(0.3), rotation,
        np.zeros((n, 3)), DT, f(0.5), f(0.0036), f(3.0), f(0.1), f(0.4), f(10.0), f(2.0),
        estimate, variance, f(5.0), f(0.0), f(0.0), valid, good_for, learned, in_use, vel_int,
    )  # fmt: skip
    assert valid[0] and learned[0] and not learned[1]
    assert abs(in_use[0] - 0.3) < 0.01 and in_use[1] == 0.5
    np.testing.assert_allclose(in_use * (G_M_S2 - vel_int[:, 2]), before, rtol=1e-12)
