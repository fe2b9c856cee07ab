"""The inner loop as the fleet runs it: attitude P -> rate PID -> mixer, with the fleet's masks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from autopilot_emu.control.inner_loop import RATE_INTEGRATOR_LIMIT, InnerLoop, InnerLoopGains
from autopilot_emu.control.mixer import MAX_ROTORS, TYPHOON_H480_ROTORS, Mixer, RotorGeometry
from autopilot_emu.params import ParamStore

QUAD_X = ((0.15, 0.15, 0.05), (-0.15, -0.15, 0.05), (0.15, -0.15, -0.05), (-0.15, 0.15, -0.05))
DT = 0.004


class Tick:
    """An N-vehicle inner loop with PX4-like gains, and its inputs."""

    def __init__(self, rows=(TYPHOON_H480_ROTORS,)):
        n = len(rows)
        self.n = n
        t3 = lambda xyz: np.tile(np.asarray(xyz, dtype=float), (n, 1))  # noqa: E731
        gains = InnerLoopGains(
            attitude_p=t3([6.5, 6.5, 2.8]),
            rate_max_rad_s=np.radians(t3([220.0, 220.0, 200.0])),
            rate_p=t3([0.15, 0.15, 0.2]),
            rate_i=t3([0.2, 0.2, 0.1]),
            rate_d=t3([0.0, 0.0, 0.0]),
        )
        self.loop = InnerLoop(gains, Mixer([RotorGeometry.from_rows(r) for r in rows]))
        self.q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
        self.rates = np.zeros((n, 3))
        self.q_sp = self.q.copy()
        self.thrust = np.full(n, 0.4)
        self.overridden = np.zeros(n, dtype=bool)
        self.rate_target = np.full((n, 3), np.nan)
        self.active = np.ones(n, dtype=bool)
        self.armed = np.ones(n, dtype=bool)

    def set_gains(self, **changes: np.ndarray) -> None:
        """New gains (frozen: a parameter change builds new ones)."""
        self.loop.gains = dataclasses.replace(self.loop.gains, **changes)

    def run(self) -> np.ndarray:
        self.loop.step(
            q=self.q,
            rates_rad_s=self.rates,
            q_sp=self.q_sp,
            thrust=self.thrust,
            overridden=self.overridden,
            rate_target_rad_s=self.rate_target,
            dt_s=DT,
            active=self.active,
            armed=self.armed,
        )
        return self.loop.state.outputs


def roll_quaternion(angle_rad):
    return np.array([math.cos(angle_rad / 2), math.sin(angle_rad / 2), 0.0, 0.0])


def test_roll_error_gives_the_p_law_rate_and_the_pid_torque():
    """A 0.1 rad roll setpoint: rate = 2 sin(0.05) MC_ROLL_P, torque = MC_ROLLRATE_P rate; the
    integrator takes MC_ROLLRATE_I e dt scaled by PX4's i_factor 1 - (e / 400 deg/s)²."""
    t = Tick()
    t.q_sp[0] = roll_quaternion(0.1)
    t.run()
    s = t.loop.state
    want_rate = 2.0 * math.sin(0.05) * 6.5
    np.testing.assert_allclose(s.rate_sp_rad_s[0], [want_rate, 0.0, 0.0], atol=1e-12)
    i_factor = 1.0 - (want_rate / math.radians(400.0)) ** 2
    want_integral = 0.2 * DT * want_rate * i_factor
    np.testing.assert_allclose(s.rate_integral[0], [want_integral, 0.0, 0.0], atol=1e-12)
    # Roll right (positive) raises the left rotors (body y < 0) above the right ones.
    y = np.asarray(TYPHOON_H480_ROTORS)[:, 1]
    out = s.outputs[0, :6]
    assert out[y < 0].min() > out[y > 0].max()


def test_the_short_way_round_and_the_rate_limit():
    """A 350 deg roll setpoint is a -10 deg error; a 170 deg error hits MC_ROLLRATE_MAX."""
    t = Tick()
    t.q_sp[0] = roll_quaternion(math.radians(350.0))
    t.run()
    rate_sp = t.loop.state.rate_sp_rad_s
    assert rate_sp[0, 0] < 0.0
    np.testing.assert_allclose(rate_sp[0, 0], -2.0 * math.sin(math.radians(5.0)) * 6.5)
    t.q_sp[0] = roll_quaternion(math.radians(170.0))
    t.set_gains(attitude_p=np.full((1, 3), 50.0))
    t.run()
    np.testing.assert_allclose(rate_sp[0], [math.radians(220.0), 0.0, 0.0])


def test_offboard_rates_replace_the_attitude_loop_per_axis_and_are_clamped():
    t = Tick()
    t.q_sp[0] = roll_quaternion(0.1)
    t.overridden[0] = True
    t.rate_target[0] = [np.nan, 100.0, -0.5]
    t.run()
    np.testing.assert_allclose(
        t.loop.state.rate_sp_rad_s[0],
        [2.0 * math.sin(0.05) * 6.5, math.radians(220.0), -0.5],
        atol=1e-12,
    )


def test_masks_idle_inactive_and_zero_disarmed_vehicles_even_with_nan_setpoints():
    t = Tick(rows=(TYPHOON_H480_ROTORS, QUAD_X, QUAD_X))
    t.active[1] = False
    t.armed[2] = t.active[2] = False
    t.q_sp[1:] = np.nan
    out = t.run()
    np.testing.assert_allclose(out[1], [0.15] * 4 + [0.0] * 4)
    np.testing.assert_array_equal(out[2], 0.0)
    np.testing.assert_allclose(out[0, :6], 0.4, rtol=2e-3)  # THR_MDL_FAC 0: output = thrust
    np.testing.assert_array_equal(t.loop.state.rate_integral[1], np.nan)  # NaN * 0 is NaN too


def test_rate_integrator_is_masked_by_active_and_clamped_against_windup():
    """A huge MC_ROLLRATE_I on a persistent error: the integrator stops at its bound, and it
    does not move at all for an inactive vehicle."""
    t = Tick(rows=(QUAD_X, QUAD_X))
    t.active[1] = False
    t.set_gains(rate_i=np.full((2, 3), 1e3))
    t.q_sp[:] = roll_quaternion(0.5)
    for _ in range(3):
        t.run()
        integral = t.loop.state.rate_integral
        np.testing.assert_allclose(integral[0], [RATE_INTEGRATOR_LIMIT, 0.0, 0.0])
        np.testing.assert_array_equal(integral[1], 0.0)


def test_rate_integrator_unwinds_at_once_when_the_error_reverses():
    """Clamped (not accumulated past the bound), the integrator leaves it on the first sample
    of a reversed error: the PX4 anti-windup, not a wound-up integrator that takes seconds."""
    t = Tick(rows=(QUAD_X,))
    t.set_gains(rate_i=np.full((1, 3), 50.0))
    t.q_sp[0] = roll_quaternion(0.5)
    for _ in range(100):
        t.run()
    assert t.loop.state.rate_integral[0, 0] == RATE_INTEGRATOR_LIMIT
    t.q_sp[0] = roll_quaternion(-0.5)
    t.run()
    assert t.loop.state.rate_integral[0, 0] < RATE_INTEGRATOR_LIMIT - 0.01


def test_derivative_acts_on_the_measured_rate_not_the_setpoint():
    """MC_*RATE_D on the measurement: a rate setpoint step gives no derivative kick; a change
    of the measured rate does, against the change."""
    with_d, without_d = Tick(rows=(QUAD_X,)), Tick(rows=(QUAD_X,))
    with_d.set_gains(rate_d=np.full((1, 3), 0.003))
    roll_arm = -np.asarray(QUAD_X)[:, 1]
    for t in (with_d, without_d):
        t.overridden[0] = True
        t.rate_target[0] = [1.0, 0.0, 0.0]  # a step from rest
    np.testing.assert_array_equal(with_d.run(), without_d.run())
    for t in (with_d, without_d):
        t.rates[0, 0] = 0.5  # the vehicle starts rolling
    moment = [(roll_arm * t.run()[0, :4]).sum() for t in (with_d, without_d)]
    assert moment[0] < moment[1]


def test_a_saturating_vehicle_keeps_roll_and_stays_within_range():
    """Full roll and yaw at high thrust: outputs 0..1 and the roll torque survives."""
    t = Tick(rows=(QUAD_X,))
    t.thrust[:] = 0.9
    t.q_sp[0] = [math.cos(0.5), math.sin(0.5) * 0.6, 0.0, math.sin(0.5) * 0.8]
    t.set_gains(rate_p=np.full((1, 3), 10.0))
    out = t.run()[0, :4]
    assert np.all((out >= 0.0) & (out <= 1.0))
    r = np.asarray(QUAD_X)
    assert (-r[:, 1] * out).sum() > 0.0  # positive roll moment (thrust fraction = output)


def test_each_vehicle_of_an_unsaturated_fleet_matches_flying_alone():
    rng = np.random.default_rng(0)
    rows = (TYPHOON_H480_ROTORS, QUAD_X, TYPHOON_H480_ROTORS)
    fleet = Tick(rows=rows)
    q = rng.normal(size=(3, 4)) * 0.05 + [1.0, 0.0, 0.0, 0.0]
    fleet.q = q / np.linalg.norm(q, axis=1, keepdims=True)
    fleet.rates = rng.normal(size=(3, 3)) * 0.1
    outputs = fleet.run()
    for i, geometry in enumerate(rows):
        alone = Tick(rows=(geometry,))
        alone.q, alone.rates = fleet.q[i : i + 1].copy(), fleet.rates[i : i + 1].copy()
        np.testing.assert_allclose(alone.run()[0], outputs[i], atol=1e-12)
    assert outputs.shape == (3, MAX_ROTORS)


def test_gains_and_mixer_follow_the_parameters():
    """MC_* gains are read per vehicle (MC_*RATE_MAX in degrees/s -> rad/s); a changed rotor
    layout rebuilds the mixer, an unchanged one keeps it."""
    params = [ParamStore(), ParamStore({"MC_ROLLRATE_MAX": 90.0, "MC_PITCH_P": 3.0})]
    loop = InnerLoop.from_params(params)
    g = loop.gains
    np.testing.assert_allclose(g.rate_max_rad_s[:, 0], np.radians([220.0, 90.0]))
    np.testing.assert_allclose(g.attitude_p[:, 1], [6.5, 3.0])
    np.testing.assert_array_equal(g.packed[0], g.attitude_p)
    mixer = loop.mixer
    loop.set_params(params)
    assert loop.mixer is mixer
    params[1].set("CA_ROTOR_COUNT", 4)
    loop.set_params(params)
    assert loop.mixer is not mixer and list(loop.mixer.rotor_counts) == [6, 4]
