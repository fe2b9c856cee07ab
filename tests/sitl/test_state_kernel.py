"""The compiled state kernel against PyBullet's own rotation matrices."""

from __future__ import annotations

import numpy as np
import pybullet as p

from sitl.physics.state_kernel import complete_state, wrench_to_world


def test_rotation_and_body_velocity_match_pybullet() -> None:
    """Rows are copied; R is getMatrixFromQuaternion (unnormalised input too); v_flu = R^T v."""
    rng = np.random.default_rng(3)
    n = 50
    q = rng.normal(size=(n, 4))
    q[5:] /= np.linalg.norm(q[5:], axis=1, keepdims=True)  # the first five stay unnormalised
    read = np.concatenate(
        [rng.normal(size=(n, 3)), q, rng.normal(size=(n, 3)), rng.normal(size=(n, 3))], axis=1
    )
    state = np.full((n, 22), np.nan)
    v_flu = np.full((n, 1, 3), np.nan)
    complete_state(read.ravel().copy(), state, v_flu)
    np.testing.assert_array_equal(state[:, :13], read)
    expected = np.array([p.getMatrixFromQuaternion(row.tolist()) for row in q]).reshape(n, 3, 3)
    rotation = state[:, 13:22].reshape(n, 3, 3)
    np.testing.assert_allclose(rotation, expected, atol=1e-12)
    velocity = read[:, 7:10]
    np.testing.assert_allclose(v_flu[:, 0], np.einsum("kij,ki->kj", rotation, velocity), atol=1e-12)


def test_wrench_to_world_rotates_force_and_torque() -> None:
    """Both halves of the body wrench come out as R @ v (FLU -> ENU)."""
    rng = np.random.default_rng(4)
    n = 7
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    read = np.concatenate([np.zeros((n, 3)), q, np.zeros((n, 6))], axis=1)
    state = np.zeros((n, 22))
    complete_state(read.ravel().copy(), state, np.zeros((n, 1, 3)))
    wrench = rng.normal(size=(n, 6))
    out = np.full((n, 2, 3), np.nan)
    wrench_to_world(wrench, state, out)
    rotation = state[:, 13:22].reshape(n, 3, 3)
    np.testing.assert_allclose(out[:, 0], np.einsum("kij,kj->ki", rotation, wrench[:, :3]))
    np.testing.assert_allclose(out[:, 1], np.einsum("kij,kj->ki", rotation, wrench[:, 3:]))
