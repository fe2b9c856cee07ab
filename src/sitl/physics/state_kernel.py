"""Compiled kernel completing the bodies' state after it is read from PyBullet (numba).

PyBullet returns pose and velocity; the rotation matrices and the body-frame velocities the rotor
model needs follow from them, for every vehicle in one call.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def complete_state(read: np.ndarray, state: np.ndarray, velocity_flu_m_s: np.ndarray) -> None:
    """Copy what PyBullet returned into the state rows, with rotation and body-frame velocity.

    Args:
        read: ``(13 N,)`` per body: position (3), quaternion x, y, z, w (4), ENU velocity (3),
            ENU angular velocity (3).
        state: ``(N, 22)`` out: those 13 values, then the FLU->ENU rotation matrix (9,
            row-major), computed as Bullet's ``btMatrix3x3::setRotation`` does.
        velocity_flu_m_s: ``(N, 1, 3)`` out: the velocity in body FLU axes (``v^T R``).
    """
    for k in range(state.shape[0]):
        for j in range(13):
            state[k, j] = read[13 * k + j]
        x = state[k, 3]
        y = state[k, 4]
        z = state[k, 5]
        w = state[k, 6]
        s = 2.0 / (x * x + y * y + z * z + w * w)
        xs = x * s
        ys = y * s
        zs = z * s
        wx = w * xs
        wy = w * ys
        wz = w * zs
        xx = x * xs
        xy = x * ys
        xz = x * zs
        yy = y * ys
        yz = y * zs
        zz = z * zs
        r = state[k, 13:22]
        r[0] = 1.0 - (yy + zz)
        r[1] = xy - wz
        r[2] = xz + wy
        r[3] = xy + wz
        r[4] = 1.0 - (xx + zz)
        r[5] = yz - wx
        r[6] = xz - wy
        r[7] = yz + wx
        r[8] = 1.0 - (xx + yy)
        v0 = state[k, 7]
        v1 = state[k, 8]
        v2 = state[k, 9]
        for c in range(3):
            velocity_flu_m_s[k, 0, c] = v0 * r[c] + v1 * r[3 + c] + v2 * r[6 + c]


@numba.njit(cache=True, error_model="numpy")
def wrench_to_world(wrench_flu: np.ndarray, state: np.ndarray, out: np.ndarray) -> None:
    """Rotate each body's ``[F_flu, tau_flu]`` (N, 6) into world ENU axes, ``out`` (N, 2, 3).

    The rotation is the state's FLU->ENU matrix (``complete_state``): ``v_enu = R v_flu``.
    """
    for k in range(wrench_flu.shape[0]):
        r = state[k, 13:22]
        for half in range(2):
            x = wrench_flu[k, 3 * half]
            y = wrench_flu[k, 3 * half + 1]
            z = wrench_flu[k, 3 * half + 2]
            for c in range(3):
                out[k, half, c] = r[3 * c] * x + r[3 * c + 1] * y + r[3 * c + 2] * z
