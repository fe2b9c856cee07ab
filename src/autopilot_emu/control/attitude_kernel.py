"""Compiled attitude P law (PX4 mc_att_control) on one vehicle's row of the fleet arrays.

Shared by :func:`autopilot_emu.control.attitude.attitude_rate_setpoint` and the fleet's fused
per-IMU-sample kernel (:mod:`autopilot_emu.control.inner_loop_kernel`). NaN propagates as in
numpy (``np.maximum`` / ``np.minimum`` on scalars keep NaN).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def attitude_rate_row(
    i: int,
    q: np.ndarray,
    q_sp: np.ndarray,
    gains_rpy: np.ndarray,
    rate_max_rad_s: np.ndarray,
    yaw_rate_ff_rad_s: np.ndarray,
    use_ff: bool,
    out: np.ndarray,
) -> None:
    """Body-rate setpoint of vehicle i into ``out[i]`` (rad/s), clamped to ±rate_max."""
    w, x, y, z = q[i, 0], -q[i, 1], -q[i, 2], -q[i, 3]  # q^-1
    a, b, c, d = q_sp[i, 0], q_sp[i, 1], q_sp[i, 2], q_sp[i, 3]
    ew = w * a - x * b - y * c - z * d
    ex = w * b + x * a + y * d - z * c
    ey = w * c - x * d + y * a + z * b
    ez = w * d + x * c - y * b + z * a
    s = -1.0 if ew < 0.0 else 1.0  # the short way round
    r0 = 2.0 * (ex * s) * gains_rpy[i, 0]
    r1 = 2.0 * (ey * s) * gains_rpy[i, 1]
    r2 = 2.0 * (ez * s) * gains_rpy[i, 2]
    if use_ff:
        # A yaw rate about NED z expressed in the body frame (third row of R(q)).
        ff = yaw_rate_ff_rad_s[i]
        if math.isnan(ff):
            ff = 0.0
        elif math.isinf(ff):
            ff = np.finfo(np.float64).max if ff > 0.0 else -np.finfo(np.float64).max
        qw, qx, qy, qz = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
        r0 += ff * (2.0 * (qx * qz - qw * qy))
        r1 += ff * (2.0 * (qy * qz + qw * qx))
        r2 += ff * (qw * qw - qx * qx - qy * qy + qz * qz)
    m0, m1, m2 = rate_max_rad_s[i, 0], rate_max_rad_s[i, 1], rate_max_rad_s[i, 2]
    out[i, 0] = fmin(fmax(r0, -m0), m0)
    out[i, 1] = fmin(fmax(r1, -m1), m1)
    out[i, 2] = fmin(fmax(r2, -m2), m2)


@numba.njit(cache=True, error_model="numpy")
def attitude_rate_kernel(
    q: np.ndarray,
    q_sp: np.ndarray,
    gains_rpy: np.ndarray,
    rate_max_rad_s: np.ndarray,
    yaw_rate_ff_rad_s: np.ndarray,
    use_ff: bool,
    out: np.ndarray,
) -> None:
    """:func:`attitude_rate_row` for every vehicle."""
    for i in range(q.shape[0]):
        attitude_rate_row(i, q, q_sp, gains_rpy, rate_max_rad_s, yaw_rate_ff_rad_s, use_ff, out)
