"""The fleet filter's compiled kernels against hand-checked cases: fusion, prediction, masks, NaN.

The filter runs on numba kernels (``autopilot_emu.estimator_kernels``); these tests pin their
arithmetic to the textbook equations (a scalar Kalman update, Phi P Phi^T + Q built densely,
constant-acceleration kinematics) and the masked-fleet semantics of the former numpy code.
"""

from __future__ import annotations

import numpy as np
import pytest

from autopilot_emu.estimator import GRAVITY_M_S2, FleetEstimator

DT = 1.0 / 250.0
LEVEL_ACCEL = np.array([0.0, 0.0, -GRAVITY_M_S2])
"""Specific force of a level vehicle at rest, body FRD, m/s²."""


def test_scalar_fusion_of_one_axis_is_the_kalman_update():
    """Fusing a direct observation of north position: gain P/(P+R), variance P R/(P+R)."""
    est = FleetEstimator(2)
    p_nn = est.P[0, 6, 6]
    var, innov = 0.3, 2.0
    before_other = est.position_ned_m[1].copy()
    est._fuse_axis(6, np.array([innov, 5.0]), np.full(2, var), np.array([True, False]))
    gain = p_nn / (p_nn + var)
    assert est.position_ned_m[0, 0] == pytest.approx(gain * innov, rel=1e-12)
    assert est.P[0, 6, 6] == pytest.approx(p_nn * var / (p_nn + var), rel=1e-12)
    assert est.position_ned_m[0, 1:] == pytest.approx([0.0, 0.0], abs=1e-15)
    # The masked-out vehicle is untouched (its innovation is ignored).
    assert np.array_equal(est.position_ned_m[1], before_other)
    assert est.P[1, 6, 6] == p_nn


def test_a_masked_fleet_update_clamps_the_others_biases_to_the_current_limit():
    """As the vectorised update: when any vehicle fuses, the others' biases are re-clamped."""
    est = FleetEstimator(2)
    est.accel_bias_m_s2[1] = [0.0, 0.0, 0.3]
    est.params = est.params.__class__(
        **{**est.params.__dict__, "abias_lim_m_s2": np.array([0.4, 0.2])}
    )
    est._fuse_axis(6, np.array([0.1, 0.0]), np.full(2, 1.0), np.array([True, False]))
    assert est.accel_bias_m_s2[1, 2] == pytest.approx(0.2)
    # No vehicle fusing: nothing changes at all.
    est.accel_bias_m_s2[1, 2] = 0.3
    est._fuse_axis(6, np.zeros(2), np.ones(2), np.zeros(2, dtype=bool))
    assert est.accel_bias_m_s2[1, 2] == 0.3


def test_covariance_prediction_is_phi_p_phi_transposed_plus_q():
    """The sparse kernel equals the dense Phi P Phi^T + Q of the error-state dynamics."""
    est = FleetEstimator(1)
    rng = np.random.default_rng(3)
    a = rng.standard_normal((15, 15))
    est.P[0] = a @ a.T * 0.01 + np.eye(15) * 0.1
    p0 = est.P[0].copy()
    tilted = np.array([[2.0, -1.5, -9.4]])  # aligns to a tilted attitude
    est.align_heading(tilted, np.array([[0.1, 0.2, 0.4]]), np.ones(1, bool))
    est.attitude_ok[:] = False  # no fake-position fusion in this interval
    accel = np.array([[0.5, -0.3, -9.0]])
    dt = 0.005
    r_start = est.r[0].copy()
    # One prediction interval (two samples) of constant body specific force and zero rates.
    for _ in range(round(est.config.predict_period_s / dt)):
        est.update_imu(accel, np.zeros((1, 3)), dt)
    dt = est.config.predict_period_s
    r = est.r[0]
    assert np.allclose(r, r_start)  # no rotation: the kernel used the same R throughout
    f_ned = r @ accel[0]
    phi = np.eye(15)
    phi[0:3, 9:12] = -r * dt
    phi[3:6, 0:3] = -_skew(f_ned * dt)
    phi[3:6, 12:15] = -r * dt
    phi[6:9, 3:6] = np.eye(3) * dt
    prm = est.params
    q = np.diag(
        np.repeat(
            [
                (prm.gyr_noise_rad_s[0] * dt) ** 2,
                (prm.acc_noise_m_s2[0] * dt) ** 2,
                0.0,
                (prm.gyr_b_noise_rad_s2[0] * dt) ** 2,
                (prm.acc_b_noise_m_s3[0] * dt) ** 2,
            ],
            3,
        )
    )
    assert np.allclose(est.P[0], phi @ p0 @ phi.T + q, rtol=1e-12, atol=1e-15)
    assert np.array_equal(est.P[0], est.P[0].T)


def test_constant_acceleration_and_yaw_rate_integrate_exactly():
    """p = a t²/2, v = a t for a constant NED acceleration; yaw = rate t for a constant rate."""
    est = FleetEstimator(1)
    est.attitude_ok[:] = False  # no fake-position fusion: pure strapdown
    accel = np.array([[1.0, 0.0, -GRAVITY_M_S2]])
    ticks = 250
    for _ in range(ticks):
        est.update_imu(accel, np.zeros((1, 3)), DT)
    t = ticks * DT
    assert est.position_ned_m[0] == pytest.approx([0.5 * t * t, 0.0, 0.0], abs=1e-9)
    assert est.velocity_ned_m_s[0] == pytest.approx([t, 0.0, 0.0], abs=1e-12)
    rate = 0.5
    for _ in range(ticks):
        est.update_imu(np.array([LEVEL_ACCEL]), np.array([[0.0, 0.0, rate]]), DT)
    yaw = np.arctan2(est.r[0, 1, 0], est.r[0, 0, 0])
    assert yaw == pytest.approx(rate * t, abs=1e-6)
    assert np.linalg.norm(est.q[0]) == pytest.approx(1.0, abs=1e-15)
    assert np.allclose(est.r[0], _rotation(est.q[0]), atol=1e-15)


def test_each_imu_sample_gives_a_new_rates_array():
    """Callers keep the previous sample's rates (a D term): it must not change under them."""
    est = FleetEstimator(1)
    est.update_imu(np.array([LEVEL_ACCEL]), np.array([[0.1, 0.0, 0.0]]), DT)
    previous = est.rates_rad_s
    est.update_imu(np.array([LEVEL_ACCEL]), np.array([[0.3, 0.0, 0.0]]), DT)
    assert previous[0, 0] == pytest.approx(0.1)
    assert est.rates_rad_s[0, 0] == pytest.approx(0.3)


def test_samples_may_be_views_of_a_message_array():
    """Non-contiguous columns of one sample array (as the fleet unpacks HIL_SENSOR) work."""
    raw = np.tile([0.0, 0.0, -GRAVITY_M_S2, 0.01, -0.02, 0.03, 0.2, 0.0, 0.4, 480.0], (3, 1))
    mask = np.ones(3, dtype=bool)
    a, b = FleetEstimator(3), FleetEstimator(3)
    for est, sample in ((a, raw), (b, raw.copy())):
        acc, gyro, mag = sample[:, 0:3], sample[:, 3:6], sample[:, 6:9]
        if est is b:
            acc, gyro, mag = acc.copy(), gyro.copy(), mag.copy()
        est.align_heading(acc, mag, mask)
        for _ in range(30):
            est.update_mag(mag, mask)
            est.update_imu(acc, gyro, DT)
            est.update_baro(sample[:, 9], mask)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.P, b.P)
    assert np.array_equal(a.position_ned_m, b.position_ned_m)
    # Lists are accepted too (converted once).
    a.update_imu([[0.0, 0.0, -GRAVITY_M_S2]] * 3, [[0.0, 0.0, 0.0]] * 3, DT)
    assert np.isfinite(a.position_ned_m).all()


def test_nan_samples_are_gated_out_and_masks_are_respected():
    """A NaN magnetometer or barometer sample fails its gate; masked vehicles see nothing."""
    est = FleetEstimator(2)
    mag = np.array([[0.2, 0.0, 0.4], [np.nan, 0.0, 0.4]])
    est.align_heading(
        np.tile(LEVEL_ACCEL, (2, 1)), np.tile([0.2, 0.0, 0.4], (2, 1)), np.ones(2, bool)
    )
    for _ in range(10):
        est.update_imu(np.tile(LEVEL_ACCEL, (2, 1)), np.zeros((2, 3)), DT)
    q_before = est.q.copy()
    est.update_mag(mag, np.array([True, True]))
    assert est.mag_seen_s[1] == est.time_s and est.mag_accepted_s[1] == -np.inf
    assert np.isfinite(est.q).all() and np.allclose(est.q[1], q_before[1], atol=1e-15)
    assert est.mag_accepted_s[0] == est.time_s
    est.update_baro(np.array([480.0, np.nan]), np.array([True, True]))
    z = est.position_ned_m[:, 2].copy()
    est.update_baro(np.array([480.5, np.nan]), np.array([True, True]))
    assert np.isfinite(est.position_ned_m).all()
    assert est.position_ned_m[1, 2] == z[1]
    assert est.position_ned_m[0, 2] < z[0]  # 0.5 m higher pressure altitude: moved up
    seen = est.mag_seen_s.copy()
    est.update_mag(mag, np.array([False, False]))
    assert np.array_equal(est.mag_seen_s, seen)


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _rotation(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z],
        ]
    )


def test_one_sensor_call_equals_the_three_stage_calls():
    """update_sensors is update_mag, update_imu, update_baro in one kernel call, bit for bit."""
    rng = np.random.default_rng(5)
    a, b = FleetEstimator(3), FleetEstimator(3)
    for est in (a, b):
        est.align_heading(
            np.tile(LEVEL_ACCEL, (3, 1)), np.tile([0.2, 0.0, 0.4], (3, 1)), np.ones(3, bool)
        )
    for tick in range(300):
        acc = LEVEL_ACCEL + 0.3 * rng.standard_normal((3, 3))
        gyro = 0.02 * rng.standard_normal((3, 3))
        mag = np.array([0.2, 0.0, 0.4]) + 0.01 * rng.standard_normal((3, 3))
        baro = 480.0 + 0.2 * rng.standard_normal(3)
        has_mag = rng.random(3) < 0.4
        has_baro = np.full(3, tick % 5 == 0)
        a.update_mag(mag, has_mag)
        a.update_imu(acc, gyro, DT)
        a.update_baro(baro, has_baro)
        b.update_sensors(acc, gyro, DT, mag, has_mag, baro, has_baro)
    for name in ("q", "P", "position_ned_m", "velocity_ned_m_s", "gyro_bias_rad_s", "rates_rad_s"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.array_equal(a.mag_accepted_s, b.mag_accepted_s) and a.time_s == b.time_s
