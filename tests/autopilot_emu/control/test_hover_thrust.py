"""The hover-thrust estimator learns the hover thrust from thrust and vertical acceleration."""

import numpy as np

from autopilot_emu.control.hover_thrust import G_M_S2, HoverThrustEstimator, HoverThrustParams

DT = 0.02


def _params(n):
    f = lambda v: np.full(n, float(v))  # noqa: E731
    return HoverThrustParams(f(0.5), f(0.0036), f(3.0), f(0.1), f(10.0), f(2.0), f(0.4))


def _fly(hte, true_hover, seconds, rng, active=None, noise=0.5):
    n = len(true_hover)
    active = np.ones(n, dtype=bool) if active is None else active
    for k in range(int(seconds / DT)):
        thrust = true_hover * (1.0 + 0.1 * np.sin(0.7 * k * DT))
        acc = G_M_S2 * thrust / true_hover - G_M_S2 + rng.normal(0.0, noise, n)
        hte.update(active, acc, thrust, np.zeros((n, 3)), DT)


def test_converges_from_the_px4_default_to_the_true_hover_thrust_and_becomes_valid():
    rng = np.random.default_rng(1)
    hte = HoverThrustEstimator(_params(3))
    true = np.array([0.22, 0.35, 0.6])
    _fly(hte, true, 1.5, rng)
    np.testing.assert_allclose(hte.hover_thrust, true, atol=0.01)
    assert not hte.valid.any()  # the variance must stay small for 2 s first
    _fly(hte, true, 3.0, rng)
    np.testing.assert_allclose(hte.hover_thrust, true, rtol=0.02)
    assert hte.valid.all()


def test_inactive_vehicles_keep_the_initial_guess_and_reset_restores_it():
    rng = np.random.default_rng(2)
    hte = HoverThrustEstimator(_params(2))
    _fly(hte, np.array([0.22, 0.22]), 5.0, rng, active=np.array([True, False]))
    assert abs(hte.hover_thrust[0] - 0.22) < 0.01
    assert hte.hover_thrust[1] == 0.5 and not hte.valid[1]
    hte.reset(np.array([True, False]))
    assert hte.hover_thrust[0] == 0.5 and not hte.valid[0]


def test_an_outlier_is_gated_out():
    rng = np.random.default_rng(3)
    hte = HoverThrustEstimator(_params(1))
    true = np.array([0.3])
    _fly(hte, true, 5.0, rng)
    before = hte.hover_thrust.copy()
    hte.update(np.array([True]), np.array([40.0]), true, np.zeros((1, 3)), DT)  # a bump
    assert abs(hte.hover_thrust[0] - before[0]) < 1e-4


def test_estimate_stays_within_thr_range_of_mpc_thr_hover():
    rng = np.random.default_rng(4)
    params = _params(1)
    params.range = np.array([0.1])
    hte = HoverThrustEstimator(params)
    _fly(hte, np.array([0.22]), 5.0, rng)
    assert hte.hover_thrust[0] >= 0.4 - 1e-9
