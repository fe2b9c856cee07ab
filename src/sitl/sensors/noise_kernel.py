"""Compiled per-sample kernels of the sensor error models (numba; the models: noise.py, imu.py).

Each replaces about ten small numpy calls per sample with one call; the random numbers stay with
numpy's generator (drawn by the caller, in the same order as before).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def biased_white_noise(
    z: np.ndarray,
    bias: np.ndarray,
    phi: np.ndarray,
    sigma_bias: np.ndarray,
    sigma_white: np.ndarray,
    turn_on_bias: np.ndarray,
    error_out: np.ndarray,
) -> None:
    """Advance the Gauss-Markov bias and write one sample's total error (flat arrays, size m).

    ``z`` is ``(2 m,)``: m standard normals for the bias walk, then m for the white noise.
    ``b = phi b + sigma_bias z_walk``; ``error = sigma_white z_white + b + turn_on_bias``.
    """
    m = bias.size
    for k in range(m):
        b = bias[k] * phi[k] + z[k] * sigma_bias[k]
        bias[k] = b
        error_out[k] = z[m + k] * sigma_white[k] + b + turn_on_bias[k]


@numba.njit(cache=True, error_model="numpy")
def imu_sample(
    rotation_flu_to_enu: np.ndarray,
    velocity_enu_m_s: np.ndarray,
    last_velocity_enu_m_s: np.ndarray,
    angular_velocity_enu_rad_s: np.ndarray,
    dt_s: float,
    first: bool,
    gravity_m_s2: float,
    error: np.ndarray,
    out: np.ndarray,
) -> None:
    """Specific force and angular rate in body FRD plus their error, into ``out`` (N, 2, 3).

    The specific force is the mean acceleration since the previous sample (velocity difference
    over ``dt_s``; zero on the first sample) minus gravity, rotated into the body with the
    attitude now. ``last_velocity_enu_m_s`` is updated to the velocity now. ``error`` is
    ``(N, 2, 3)`` (``biased_white_noise``'s output).
    """
    n = velocity_enu_m_s.shape[0]
    inv_dt = 1.0 / dt_s
    for k in range(n):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        if not first:
            a0 = (velocity_enu_m_s[k, 0] - last_velocity_enu_m_s[k, 0]) * inv_dt
            a1 = (velocity_enu_m_s[k, 1] - last_velocity_enu_m_s[k, 1]) * inv_dt
            a2 = (velocity_enu_m_s[k, 2] - last_velocity_enu_m_s[k, 2]) * inv_dt
        a2 = a2 + gravity_m_s2
        for j in range(3):
            last_velocity_enu_m_s[k, j] = velocity_enu_m_s[k, j]
        w0 = angular_velocity_enu_rad_s[k, 0]
        w1 = angular_velocity_enu_rad_s[k, 1]
        w2 = angular_velocity_enu_rad_s[k, 2]
        r = rotation_flu_to_enu[k]
        # Row vector times R (= R^T v) gives FLU; FRD flips y and z.
        for c in range(3):
            sign = 1.0 if c == 0 else -1.0
            acc = a0 * r[0, c] + a1 * r[1, c] + a2 * r[2, c]
            rate = w0 * r[0, c] + w1 * r[1, c] + w2 * r[2, c]
            out[k, 0, c] = acc * sign + error[k, 0, c]
            out[k, 1, c] = rate * sign + error[k, 1, c]


@numba.njit(cache=True, error_model="numpy")
def field_in_body(
    rotation_flu_to_enu: np.ndarray, field_enu: np.ndarray, error: np.ndarray, out: np.ndarray
) -> None:
    """A world ENU field (N, 3) in body FRD axes plus its sensor error, into ``out`` (N, 3)."""
    for k in range(field_enu.shape[0]):
        r = rotation_flu_to_enu[k]
        f0 = field_enu[k, 0]
        f1 = field_enu[k, 1]
        f2 = field_enu[k, 2]
        for c in range(3):
            sign = 1.0 if c == 0 else -1.0
            out[k, c] = (f0 * r[0, c] + f1 * r[1, c] + f2 * r[2, c]) * sign + error[k, c]
