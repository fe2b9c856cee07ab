"""The hover-thrust loop learns the hover thrust from thrust and vertical acceleration, and hands
it to the position controller without a thrust step."""

import dataclasses

import numpy as np

from autopilot_emu.control.hover_thrust import G_M_S2, HoverThrustLoop, HoverThrustParams
from autopilot_emu.params import ParamStore

DT = 0.02


def _params(n, **changes):
    f = lambda v: np.full(n, float(v))  # noqa: E731
    params = HoverThrustParams(f(0.5), f(0.0036), f(3.0), f(0.1), f(10.0), f(2.0), f(0.4))
    return dataclasses.replace(params, **changes)


def _loop(params):
    loop = HoverThrustLoop(len(params.initial))
    loop.set_params(params)
    return loop


class Flight:
    """Inputs of the loop for n level vehicles at rest in the air (armed, flying)."""

    def __init__(self, n):
        self.flying = np.ones(n, dtype=bool)
        self.armed = np.ones(n, dtype=bool)
        self.accel = np.zeros((n, 3))
        self.thrust = np.zeros(n)
        self.rotation = np.tile(np.eye(3), (n, 1, 1))
        self.velocity = np.zeros((n, 3))
        self.velocity_integral = np.zeros((n, 3))

    def step(self, loop, acc_up, thrust):
        """One tick with upward acceleration ``acc_up`` (m/s²) under collective ``thrust``."""
        self.accel[:, 2] = -acc_up
        self.thrust[:] = thrust
        loop.step(
            flying=self.flying,
            armed=self.armed,
            accel_ned_m_s2=self.accel,
            thrust=self.thrust,
            rotation=self.rotation,
            velocity_ned_m_s=self.velocity,
            dt_s=DT,
            velocity_integral=self.velocity_integral,
        )


def _fly(loop, flight, true_hover, seconds, rng, noise=0.5):
    n = len(true_hover)
    for k in range(int(seconds / DT)):
        thrust = true_hover * (1.0 + 0.1 * np.sin(0.7 * k * DT))
        acc = G_M_S2 * thrust / true_hover - G_M_S2 + rng.normal(0.0, noise, n)
        flight.step(loop, acc, thrust)


def test_converges_from_the_px4_default_to_the_true_hover_thrust_and_becomes_valid():
    """The estimate converges first; it becomes valid (and the one in use) 2 s later."""
    rng = np.random.default_rng(1)
    loop = _loop(_params(3))
    flight = Flight(3)
    true = np.array([0.22, 0.35, 0.6])
    _fly(loop, flight, true, 1.5, rng)
    s = loop.state
    np.testing.assert_allclose(s.estimate, true, atol=0.01)
    assert not s.valid.any()  # the variance must stay small for 2 s first
    np.testing.assert_array_equal(s.in_use, 0.5)  # MPC_THR_HOVER until then
    _fly(loop, flight, true, 3.0, rng)
    np.testing.assert_allclose(s.estimate, true, rtol=0.02)
    assert s.valid.all() and s.learned.all()
    np.testing.assert_array_equal(s.in_use, s.estimate)


def test_vehicles_on_the_ground_keep_the_initial_guess_and_disarming_restores_it():
    rng = np.random.default_rng(2)
    loop = _loop(_params(2))
    flight = Flight(2)
    flight.flying[1] = False
    _fly(loop, flight, np.array([0.22, 0.22]), 5.0, rng)
    s = loop.state
    assert abs(s.estimate[0] - 0.22) < 0.01 and s.learned[0]
    assert s.estimate[1] == 0.5 and not s.valid[1] and s.in_use[1] == 0.5
    flight.armed[0] = False
    flight.flying[0] = False
    flight.step(loop, np.zeros(2), np.zeros(2))
    assert s.estimate[0] == 0.5 and not s.valid[0] and not s.learned[0]
    assert s.in_use[0] == 0.5


def test_an_outlier_is_gated_out():
    rng = np.random.default_rng(3)
    loop = _loop(_params(1))
    flight = Flight(1)
    true = np.array([0.3])
    _fly(loop, flight, true, 5.0, rng)
    before = loop.state.estimate.copy()
    flight.step(loop, np.array([40.0]), true)  # a bump
    assert abs(loop.state.estimate[0] - before[0]) < 1e-4


def test_estimate_stays_within_thr_range_of_mpc_thr_hover():
    rng = np.random.default_rng(4)
    loop = _loop(_params(1, range=np.array([0.1])))
    _fly(loop, Flight(1), np.array([0.22]), 5.0, rng)
    assert loop.state.estimate[0] >= 0.4 - 1e-9


def test_hover_thrust_hand_over_keeps_the_thrust_continuous():
    """A valid estimate replaces the hover thrust in use; the vertical integrator absorbs the
    change so that hover * (g - integrator) (the thrust at zero velocity error) is unchanged."""
    loop = _loop(_params(2))
    s = loop.state
    flight = Flight(2)
    flight.velocity_integral[:, 2] = 1.0
    before = s.in_use * (G_M_S2 - flight.velocity_integral[:, 2])
    # Vehicle 0 armed on the ground: its valid flag is cleared by the update and a value never
    # handed over stays MPC_THR_HOVER; vehicle 1 disarmed restarts.
    s.estimate[:], s.variance[:], s.valid[:], s.good_for_s[:] = 0.3, 1e-4, [True, False], 3.0
    flight.flying[:] = False
    flight.armed[1] = False
    flight.step(loop, np.zeros(2), np.full(2, 0.3))
    np.testing.assert_array_equal(s.in_use, [0.5, 0.5])
    np.testing.assert_array_equal(s.learned, [False, False])
    # Now a valid estimate in flight.
    s.estimate[:], s.variance[:], s.valid[:], s.good_for_s[:] = 0.3, 1e-5, [True, False], [3, 0]
    flight.flying[:] = flight.armed[:] = True
    flight.step(loop, np.zeros(2), np.full(2, 0.3))
    assert s.valid[0] and s.learned[0] and not s.learned[1]
    assert abs(s.in_use[0] - 0.3) < 0.01 and s.in_use[1] == 0.5
    after = s.in_use * (G_M_S2 - flight.velocity_integral[:, 2])
    np.testing.assert_allclose(after, before, rtol=1e-12)


def test_parameters_start_the_estimator_and_a_new_initial_error_resets_only_the_variance():
    """The first parameters start it at MPC_THR_HOVER with HTE_HT_ERR_INIT; later a changed
    HTE_HT_ERR_INIT resets the variance of that vehicle only, and the estimate stays."""
    params = [ParamStore({"MPC_THR_HOVER": 0.3}), ParamStore()]
    loop = HoverThrustLoop(2)
    loop.set_params(HoverThrustParams.from_params(params))
    s = loop.state
    np.testing.assert_allclose(s.estimate, [0.3, 0.5], rtol=1e-6)
    np.testing.assert_allclose(s.in_use, s.estimate)
    np.testing.assert_allclose(s.variance, 0.1**2, rtol=1e-6)
    s.estimate[:], s.variance[:] = 0.35, 1e-5
    params[1].set("HTE_HT_ERR_INIT", 0.2)
    loop.set_params(HoverThrustParams.from_params(params))
    np.testing.assert_allclose(s.variance, [1e-5, 0.2**2], rtol=1e-6)
    np.testing.assert_array_equal(s.estimate, 0.35)
