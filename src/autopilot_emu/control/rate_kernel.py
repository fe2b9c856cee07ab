"""Compiled body-rate PID (PX4 mc_rate_control) on one vehicle's row of the fleet arrays.

Compiled into the inner loop's kernel (:mod:`autopilot_emu.control.inner_loop_kernel`).
"""

from __future__ import annotations

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def rate_pid_row(
    i: int,
    rates: np.ndarray,
    rate_sp: np.ndarray,
    kp: np.ndarray,
    ki: np.ndarray,
    kd: np.ndarray,
    dt_s: float,
    integrate: np.ndarray,
    integrator_limit: float,
    integral: np.ndarray,
    prev_rates: np.ndarray,
    torque: np.ndarray,
) -> None:
    """Torque of vehicle i into ``torque[i]`` (-1..1); updates its integral and previous rates.

    Derivative on measurement; the I term integrates only where ``integrate`` (a masked-out
    vehicle's step is multiplied by 0, so NaN still propagates as in numpy).
    """
    inv_dt = 1.0 / dt_s
    gate = 1.0 if integrate[i] else 0.0
    lim = integrator_limit
    for a in range(3):
        r = rates[i, a]
        err = rate_sp[i, a] - r
        t = kp[i, a] * err + integral[i, a] - kd[i, a] * ((r - prev_rates[i, a]) * inv_dt)
        prev_rates[i, a] = r
        step = (ki[i, a] * dt_s) * err * gate
        integral[i, a] = fmin(fmax(integral[i, a] + step, -lim), lim)
        torque[i, a] = fmin(fmax(t, -1.0), 1.0)
