"""Compiled attitude P law (PX4 mc_att_control) on one vehicle's row of the fleet arrays.

Compiled into the inner loop's kernel (:mod:`autopilot_emu.control.inner_loop_kernel`). The
error quaternion q^-1 ⊗ q_sp is taken on the short way round (w >= 0); its vector part times two
is the rotation-vector error for small angles, scaled per axis by MC_*_P. Yaw has a lower gain
than roll and pitch, so tilt (which produces thrust direction) is served first. NaN propagates
as in numpy (``fmax`` / ``fmin`` keep NaN).
"""

from __future__ import annotations

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
    m0, m1, m2 = rate_max_rad_s[i, 0], rate_max_rad_s[i, 1], rate_max_rad_s[i, 2]
    out[i, 0] = fmin(fmax(r0, -m0), m0)
    out[i, 1] = fmin(fmax(r1, -m1), m1)
    out[i, 2] = fmin(fmax(r2, -m2), m2)
