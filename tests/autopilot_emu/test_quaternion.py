"""Quaternion helpers agree with scipy's Rotation (an independent implementation)."""

import numpy as np
from scipy.spatial.transform import Rotation

from autopilot_emu import quaternion as quat


def _random_q(n, seed):
    return quat.normalize(np.random.default_rng(seed).normal(size=(n, 4)))


def _scipy(q):
    return Rotation.from_quat(q[:, [1, 2, 3, 0]])


def test_rotation_matrix_matches_scipy():
    q = _random_q(20, 1)
    np.testing.assert_allclose(quat.to_rotation_matrix(q), _scipy(q).as_matrix(), atol=1e-12)


def test_product_matches_scipy_composition():
    p, q = _random_q(20, 2), _random_q(20, 3)
    ref = (_scipy(p) * _scipy(q)).as_matrix()
    np.testing.assert_allclose(quat.to_rotation_matrix(quat.multiply(p, q)), ref, atol=1e-12)


def test_matrix_round_trip_and_euler():
    q = _random_q(50, 4)
    q *= np.sign(q[:, :1])
    np.testing.assert_allclose(quat.from_rotation_matrix(quat.to_rotation_matrix(q)), q, atol=1e-12)
    rpy = quat.euler_of(quat.to_rotation_matrix(q))
    ref = _scipy(q).as_euler("ZYX")[:, ::-1]
    np.testing.assert_allclose(rpy, ref, atol=1e-9)
    np.testing.assert_allclose(
        quat.to_rotation_matrix(quat.from_euler(rpy)), quat.to_rotation_matrix(q), atol=1e-12
    )


def test_integrate_constant_rate():
    """Integrating a constant body rate for 1 s turns by rate x 1 s about that axis."""
    q = np.tile([1.0, 0, 0, 0], (1, 1))
    omega = np.array([[0.0, 0.0, 0.5]])
    for _ in range(250):
        q = quat.integrate(q, omega, 1 / 250)
    assert (
        abs(quat.euler_of(quat.to_rotation_matrix(q))[0, 2] - 0.5) < 1e-6
    )  # first-order step: O((w dt)^3) per step
