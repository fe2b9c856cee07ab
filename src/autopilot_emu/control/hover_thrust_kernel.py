"""Compiled hover-thrust estimator step (see :mod:`autopilot_emu.control.hover_thrust`).

One vehicle row at a time (:func:`reset_row`, :func:`update_row`), run for the fleet by
:func:`hover_thrust_tick_kernel` (reset of disarmed vehicles, the update, and the hand-over of a
valid estimate to the position controller), which
:meth:`autopilot_emu.control.hover_thrust.HoverThrustLoop.step` calls.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import clamp, fmax, sign

G_M_S2 = 9.80665
ACC_VAR_INIT = 5.0
"""Initial acceleration noise variance, (m/s²)²."""
ACC_VAR_MIN, ACC_VAR_MAX = 1.0, 400.0
LPF_TAU_S = 1.0
"""Time constant of the residual and signed-test-ratio low-pass filters, s."""
NOISE_TAU_S = 2.0
"""Time constant of the acceleration-noise learning, s."""
VALID_VAR = 1e-3
VALID_HOLD_S = 2.0


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def reset_row(
    i: int, initial: np.ndarray, error_init: np.ndarray, hover: np.ndarray,
    variance: np.ndarray, acc_variance: np.ndarray, residual_lpf: np.ndarray,
    ratio_lpf: np.ndarray, valid: np.ndarray, good_for_s: np.ndarray,
) -> None:  # fmt: skip
    """Vehicle i back to MPC_THR_HOVER with HTE_HT_ERR_INIT."""
    hover[i] = initial[i]
    variance[i] = error_init[i] ** 2
    acc_variance[i] = ACC_VAR_INIT
    residual_lpf[i] = 0.0
    ratio_lpf[i] = 0.0
    valid[i] = False
    good_for_s[i] = 0.0


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def update_row(
    i: int, active: bool, acc_up_m_s2: float, thrust_up: float, velocity_ned_m_s: np.ndarray,
    dt_s: float, initial: np.ndarray, process_noise: np.ndarray, gate: np.ndarray,
    thr_range: np.ndarray, vxy_threshold: np.ndarray, vz_threshold: np.ndarray,
    hover: np.ndarray, variance: np.ndarray, acc_variance: np.ndarray,
    residual_lpf: np.ndarray, ratio_lpf: np.ndarray, valid: np.ndarray, good_for_s: np.ndarray,
) -> None:  # fmt: skip
    """Predict and fuse one sample of vehicle i (not ``active``: not valid, hold time 0)."""
    if not active:
        valid[i] = False
        good_for_s[i] = 0.0
        return
    g = G_M_S2
    h = hover[i]
    pn = process_noise[i]
    var = variance[i] + (pn * dt_s) ** 2
    v = velocity_ned_m_s
    speed_xy = math.hypot(v[i, 0], v[i, 1])
    excess = fmax(speed_xy - vxy_threshold[i], abs(v[i, 2]) - vz_threshold[i])
    scale = fmax(excess + 1.0, 1.0)
    r = acc_variance[i] * scale * scale
    jac = -g * thrust_up / (h * h)
    innov_var = fmax(jac * var * jac + r, r)
    innov = acc_up_m_s2 - (g * thrust_up / h - g)
    ratio = innov * innov / (gate[i] * gate[i] * innov_var)
    gain = var * jac / innov_var
    passing = ratio < 1.0
    lo = clamp(initial[i] - thr_range[i], 0.0, 0.8)
    hi = clamp(initial[i] + thr_range[i], 0.2, 0.9)
    if passing:
        h_new = clamp(h + gain * innov, fmax(lo, 0.1), hi)
        var_new = clamp((1.0 - gain * jac) * var, 1e-10, 1.0)
        residual = acc_up_m_s2 - (g * thrust_up / h_new - g)
    else:
        h_new, var_new, residual = h, var, innov
        if abs(ratio_lpf[i]) > 0.2:  # persistent one-sided rejection: let the filter move
            var_new = var_new + 1e3 * (pn**2) * dt_s
    alpha = dt_s / (LPF_TAU_S + dt_s)
    res_lpf = residual_lpf[i] + alpha * (residual - residual_lpf[i])
    signed = clamp(sign(innov) * ratio, -1.0, 1.0)
    beta = dt_s / (NOISE_TAU_S + dt_s)
    unbiased = residual - res_lpf
    acc_var = (1.0 - beta) * acc_variance[i] + beta * (unbiased * unbiased + jac * var_new * jac)
    hover[i] = h_new
    variance[i] = var_new
    acc_variance[i] = clamp(acc_var, ACC_VAR_MIN, ACC_VAR_MAX)
    residual_lpf[i] = res_lpf
    ratio_lpf[i] = ratio_lpf[i] + alpha * (signed - ratio_lpf[i])
    good = var_new < VALID_VAR and (valid[i] or passing)
    good_for_s[i] = good_for_s[i] + dt_s if good else 0.0
    valid[i] = good and (valid[i] or good_for_s[i] >= VALID_HOLD_S)


@numba.njit(cache=True, error_model="numpy")
def hover_thrust_tick_kernel(
    flying: np.ndarray, armed: np.ndarray, accel_ned_m_s2: np.ndarray, thrust: np.ndarray,
    rotation: np.ndarray, velocity_ned_m_s: np.ndarray, dt_s: float, initial: np.ndarray,
    process_noise: np.ndarray, gate: np.ndarray, error_init: np.ndarray,
    thr_range: np.ndarray, vxy_threshold: np.ndarray, vz_threshold: np.ndarray,
    estimate: np.ndarray, variance: np.ndarray, acc_variance: np.ndarray,
    residual_lpf: np.ndarray, ratio_lpf: np.ndarray, valid: np.ndarray,
    good_for_s: np.ndarray, learned: np.ndarray, hover_in_use: np.ndarray,
    vel_int: np.ndarray,
) -> None:  # fmt: skip
    """The fleet's hover-thrust step: estimator update and the hover thrust the controller uses.

    Disarmed vehicles restart the estimator and forget what they learned. The upward part of
    the collective thrust is ``thrust * R[2, 2]``. A valid estimate replaces the hover thrust in
    use; an invalid one leaves the last valid value (or MPC_THR_HOVER if none since arming).
    When the value in use changes, the vertical velocity integrator absorbs the change so the
    thrust stays continuous (as PX4's updateHoverThrust).
    """
    g = G_M_S2
    for i in range(estimate.shape[0]):
        if not armed[i]:
            reset_row(
                i, initial, error_init, estimate, variance, acc_variance, residual_lpf,
                ratio_lpf, valid, good_for_s,
            )  # fmt: skip
            learned[i] = False
        update_row(
            i, flying[i] and armed[i], -accel_ned_m_s2[i, 2], thrust[i] * rotation[i, 2, 2],
            velocity_ned_m_s, dt_s, initial, process_noise, gate, thr_range, vxy_threshold,
            vz_threshold, estimate, variance, acc_variance, residual_lpf, ratio_lpf, valid,
            good_for_s,
        )  # fmt: skip
        old = hover_in_use[i]
        learned[i] = learned[i] or valid[i]
        kept = old if learned[i] else initial[i]
        hover = estimate[i] if valid[i] else kept
        if hover != old and old > 0.0:
            vel_int[i, 2] = g - old / hover * (g - vel_int[i, 2])
        hover_in_use[i] = hover
