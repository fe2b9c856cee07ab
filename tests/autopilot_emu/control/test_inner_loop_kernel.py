"""The fused per-IMU-sample kernel: attitude P -> rate PID -> mixer, with the fleet's masks."""

from __future__ import annotations

import math

import numpy as np

from autopilot_emu.control.inner_loop_kernel import inner_loop_kernel
from autopilot_emu.control.mixer import MAX_ROTORS, TYPHOON_H480_ROTORS, Mixer, RotorGeometry
from autopilot_emu.control.rate import RateController

QUAD_X = ((0.15, 0.15, 0.05), (-0.15, -0.15, 0.05), (0.15, -0.15, -0.05), (-0.15, 0.15, -0.05))
DT = 0.004


class Tick:
    """State and inputs of an N-vehicle fleet for the kernel, with PX4-like gains."""

    def __init__(self, rows=(TYPHOON_H480_ROTORS,)):
        n = len(rows)
        self.n = n
        self.mixer = Mixer([RotorGeometry.from_rows(r) for r in rows])
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.rates = np.zeros((n, 3))
        self.q_sp = self.q.copy()
        self.thrust = np.full(n, 0.4)
        self.att_p = np.tile([6.5, 6.5, 2.8], (n, 1))
        self.rate_max = np.radians(np.tile([220.0, 220.0, 200.0], (n, 1)))
        self.overridden = np.zeros(n, dtype=bool)
        self.rate_target = np.full((n, 3), np.nan)
        self.kp = np.tile([0.15, 0.15, 0.2], (n, 1))
        self.ki = np.tile([0.2, 0.2, 0.1], (n, 1))
        self.kd = np.zeros((n, 3))
        self.active = np.ones(n, dtype=bool)
        self.armed = np.ones(n, dtype=bool)
        self.integral = np.zeros((n, 3))
        self.prev_rates = np.zeros((n, 3))
        self.rate_sp = np.zeros((n, 3))
        self.outputs = np.zeros((n, MAX_ROTORS))

    def run(self):
        m = self.mixer
        gains = np.stack((self.att_p, self.rate_max, self.kp, self.ki, self.kd))
        inner_loop_kernel(
            self.q, self.rates, self.q_sp, self.thrust, gains, self.overridden, self.rate_target,
            DT, self.active, self.armed, RateController.integrator_limit, self.integral,
            self.prev_rates, m.matrix, m.thrust_column, m.used, m.idle_output, self.rate_sp,
            self.outputs,
        )  # fmt: skip
        return self.outputs


def roll_quaternion(angle_rad):
    return np.array([math.cos(angle_rad / 2), math.sin(angle_rad / 2), 0.0, 0.0])


def test_roll_error_gives_the_p_law_rate_and_the_pid_torque():
    """A 0.1 rad roll setpoint: rate = 2 sin(0.05) MC_ROLL_P, torque = MC_ROLLRATE_P rate."""
    t = Tick()
    t.q_sp[0] = roll_quaternion(0.1)
    t.run()
    want_rate = 2.0 * math.sin(0.05) * 6.5
    np.testing.assert_allclose(t.rate_sp[0], [want_rate, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(t.integral[0], [0.2 * DT * want_rate, 0.0, 0.0], atol=1e-12)
    # Roll right (positive) raises the left rotors (body y < 0) above the right ones.
    y = np.asarray(TYPHOON_H480_ROTORS)[:, 1]
    out = t.outputs[0, :6]
    assert out[y < 0].min() > out[y > 0].max()


def test_the_short_way_round_and_the_rate_limit():
    """A 350 deg roll setpoint is a -10 deg error; a 170 deg error hits MC_ROLLRATE_MAX."""
    t = Tick()
    t.q_sp[0] = roll_quaternion(math.radians(350.0))
    t.run()
    assert t.rate_sp[0, 0] < 0.0
    np.testing.assert_allclose(t.rate_sp[0, 0], -2.0 * math.sin(math.radians(5.0)) * 6.5)
    t.q_sp[0] = roll_quaternion(math.radians(170.0))
    t.att_p[:] = 50.0
    t.run()
    np.testing.assert_allclose(t.rate_sp[0], [math.radians(220.0), 0.0, 0.0])


def test_offboard_rates_replace_the_attitude_loop_per_axis_and_are_clamped():
    t = Tick()
    t.q_sp[0] = roll_quaternion(0.1)
    t.overridden[0] = True
    t.rate_target[0] = [np.nan, 100.0, -0.5]
    t.run()
    np.testing.assert_allclose(
        t.rate_sp[0], [2.0 * math.sin(0.05) * 6.5, math.radians(220.0), -0.5], atol=1e-12
    )


def test_masks_idle_inactive_and_zero_disarmed_vehicles_even_with_nan_setpoints():
    t = Tick(rows=(TYPHOON_H480_ROTORS, QUAD_X, QUAD_X))
    t.active[1] = False
    t.armed[2] = t.active[2] = False
    t.q_sp[1:] = np.nan
    t.run()
    np.testing.assert_allclose(t.outputs[1], [0.15] * 4 + [0.0] * 4)
    np.testing.assert_array_equal(t.outputs[2], 0.0)
    np.testing.assert_allclose(t.outputs[0, :6], math.sqrt(0.4), rtol=2e-3)
    np.testing.assert_array_equal(t.integral[1], np.nan)  # numpy's NaN * 0 is NaN too


def test_integrator_is_masked_by_active_and_clamped():
    t = Tick(rows=(QUAD_X, QUAD_X))
    t.active[1] = False
    t.ki[:] = 1e3
    t.q_sp[:] = roll_quaternion(0.5)
    t.run()
    np.testing.assert_allclose(t.integral[0], [0.3, 0.0, 0.0])
    np.testing.assert_array_equal(t.integral[1], 0.0)


def test_a_saturating_vehicle_keeps_roll_and_stays_within_range():
    """Full roll and yaw at high thrust: outputs 0..1 and the roll torque survives."""
    t = Tick(rows=(QUAD_X,))
    t.thrust[:] = 0.9
    t.q_sp[0] = [math.cos(0.5), math.sin(0.5) * 0.6, 0.0, math.sin(0.5) * 0.8]
    t.kp[:] = 10.0
    out = t.run()[0, :4]
    assert np.all((out >= 0.0) & (out <= 1.0))
    r = np.asarray(QUAD_X)
    assert (-r[:, 1] * out**2).sum() > 0.0  # positive roll moment


def test_each_vehicle_of_an_unsaturated_fleet_matches_flying_alone():
    rng = np.random.default_rng(0)
    fleet = Tick(rows=(TYPHOON_H480_ROTORS, QUAD_X, TYPHOON_H480_ROTORS))
    q = rng.normal(size=(3, 4)) * 0.05 + [1.0, 0.0, 0.0, 0.0]
    fleet.q = q / np.linalg.norm(q, axis=1, keepdims=True)
    fleet.rates = rng.normal(size=(3, 3)) * 0.1
    fleet.run()
    for i, rows in enumerate((TYPHOON_H480_ROTORS, QUAD_X, TYPHOON_H480_ROTORS)):
        alone = Tick(rows=(rows,))
        alone.q, alone.rates = fleet.q[i : i + 1].copy(), fleet.rates[i : i + 1].copy()
        np.testing.assert_allclose(alone.run()[0], fleet.outputs[i], atol=1e-12)
