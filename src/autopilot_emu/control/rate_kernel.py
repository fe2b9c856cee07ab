"""Compiled body-rate PID (PX4 mc_rate_control's RateControl) on one vehicle's row.

Compiled into the inner loop's kernel (:mod:`autopilot_emu.control.inner_loop_kernel`).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin

I_FACTOR_RATE_RAD_S = math.radians(400.0)
"""Rate error at which PX4's RateControl stops integrating (its i_factor reaches 0), rad/s."""


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def rate_pid_row(
    i: int,
    rates: np.ndarray,
    accel: np.ndarray,
    rate_sp: np.ndarray,
    kp: np.ndarray,
    ki: np.ndarray,
    kd: np.ndarray,
    dt_s: float,
    integrate: np.ndarray,
    integrator_limit: float,
    integral: np.ndarray,
    torque: np.ndarray,
) -> None:
    """Torque of vehicle i into ``torque[i]`` (-1..1); updates its integral.

    As PX4's RateControl::update: torque = P e + I - D (angular acceleration), the acceleration
    being the D-term-filtered derivative of the filtered rate (so a setpoint step gives no
    derivative kick). The I term integrates i_factor Ki e dt with i_factor = max(0, 1 -
    (e / 400 deg/s)²), which fades integration out for large errors, and only where
    ``integrate`` (a masked-out vehicle's step is multiplied by 0, so NaN still propagates).
    """
    gate = 1.0 if integrate[i] else 0.0
    lim = integrator_limit
    for a in range(3):
        err = rate_sp[i, a] - rates[i, a]
        t = kp[i, a] * err + integral[i, a] - kd[i, a] * accel[i, a]
        ratio = err / I_FACTOR_RATE_RAD_S
        i_factor = fmax(1.0 - ratio * ratio, 0.0)
        step = (ki[i, a] * dt_s) * err * i_factor * gate
        integral[i, a] = fmin(fmax(integral[i, a] + step, -lim), lim)
        torque[i, a] = fmin(fmax(t, -1.0), 1.0)
