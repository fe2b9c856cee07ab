"""The fleet's per-IMU-sample control chain as one compiled call: filters to motor outputs.

What :meth:`autopilot_emu.control.inner_loop.InnerLoop.step` runs at the IMU rate, fused so that
a tick costs one kernel call whatever the fleet size. Built from the row functions of
:mod:`gyro_filter_kernel`, :mod:`attitude_kernel`, :mod:`rate_kernel` and :mod:`mixer_kernel`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.control.attitude_kernel import attitude_rate_row
from autopilot_emu.control.gyro_filter_kernel import filter_rates_row
from autopilot_emu.control.mixer_kernel import desaturate_row, fractions_row, output_row
from autopilot_emu.control.rate_kernel import rate_pid_row
from autopilot_emu.nan_scalar import fmax, fmin


@numba.njit(cache=True, error_model="numpy")
def inner_loop_kernel(
    q: np.ndarray,
    rates: np.ndarray,
    q_sp: np.ndarray,
    thrust: np.ndarray,
    gains: np.ndarray,
    filters: np.ndarray,
    overridden: np.ndarray,
    rate_target: np.ndarray,
    dt_s: float,
    active: np.ndarray,
    armed: np.ndarray,
    integrator_limit: float,
    integral: np.ndarray,
    filter_state: np.ndarray,
    filter_primed: np.ndarray,
    matrix: np.ndarray,
    thrust_column: np.ndarray,
    used: np.ndarray,
    idle_output: float,
    thrust_model_factor: np.ndarray,
    rates_filtered: np.ndarray,
    accel: np.ndarray,
    rate_sp: np.ndarray,
    outputs: np.ndarray,
) -> None:
    """One control tick of every vehicle.

    ``gains`` (5, N, 3) are MC_*_P, MC_*RATE_MAX (rad/s), MC_*RATE_P, _I and _D per axis;
    ``filters`` (2, N, 5) the gyro and D-term low-pass coefficients. Writes the filtered rates
    and angular acceleration, the body-rate setpoints ``rate_sp`` (offboard body rates where
    ``overridden`` and finite), the rate controller's state (``integral``, the filters') and
    the motor ``outputs``: armed-idle for vehicles not ``active``, 0 for vehicles not ``armed``.
    """
    n = q.shape[0]
    att_p, rate_max, rate_p, rate_i, rate_d = gains[0], gains[1], gains[2], gains[3], gains[4]
    torque = np.empty((n, 3))
    for i in range(n):
        filter_rates_row(
            i, rates, filters, dt_s, filter_state, filter_primed, rates_filtered, accel
        )  # fmt: skip
        attitude_rate_row(i, q, q_sp, att_p, rate_max, rate_sp)
        if overridden[i]:
            for a in range(3):
                r = rate_target[i, a] if math.isfinite(rate_target[i, a]) else rate_sp[i, a]
                m = rate_max[i, a]
                rate_sp[i, a] = fmin(fmax(r, -m), m)
        rate_pid_row(
            i, rates_filtered, accel, rate_sp, rate_p, rate_i, rate_d, dt_s, active,
            integrator_limit, integral, torque,
        )  # fmt: skip
    for i in range(n):
        if fractions_row(i, torque, thrust, matrix, thrust_column, outputs):
            desaturate_row(i, torque, thrust, matrix, thrust_column, used, outputs)
        output_row(i, used, idle_output, thrust_model_factor, outputs)
        if not armed[i]:
            outputs[i, :] = 0.0
        elif not active[i]:
            for r in range(outputs.shape[1]):
                outputs[i, r] = idle_output if used[i, r] else 0.0
