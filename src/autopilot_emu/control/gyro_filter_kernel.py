"""Compiled gyro filtering of one vehicle's row: filtered body rates and angular acceleration.

Compiled into the inner loop's kernel (:mod:`autopilot_emu.control.inner_loop_kernel`), with the
coefficients of :mod:`autopilot_emu.control.gyro_filter`. Each filter is a biquad in direct form
II, as PX4's LowPassFilter2p; its state per axis is (velocity delay 1, velocity delay 2,
acceleration delay 1, acceleration delay 2, previous filtered velocity).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _biquad(x: float, c: np.ndarray, state: np.ndarray, k: int) -> float:
    """One sample through the biquad with coefficients ``c`` and delays ``state[k:k + 2]``."""
    d0 = x - state[k] * c[3] - state[k + 1] * c[4]
    y = d0 * c[0] + state[k] * c[1] + state[k + 1] * c[2]
    state[k + 1] = state[k]
    state[k] = d0
    return y


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _reset(x: float, c: np.ndarray, state: np.ndarray, k: int) -> None:
    """Delays of a biquad in steady state at input ``x`` (its output is then ``x``)."""
    gain = c[0] + c[1] + c[2]
    d = x / gain if gain != 0.0 else 0.0
    state[k] = d
    state[k + 1] = d


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def filter_rates_row(
    i: int,
    rates: np.ndarray,
    coefficients: np.ndarray,
    dt_s: float,
    state: np.ndarray,
    primed: np.ndarray,
    rates_out: np.ndarray,
    accel_out: np.ndarray,
) -> None:
    """Vehicle i's filtered rates (rad/s) and angular acceleration (rad/s²) into the outputs.

    The first sample primes the filters (velocity filter settled at it, acceleration 0), as PX4
    resets them when the sensor starts. A non-finite rate passes through as NaN for that sample
    and leaves the filter state as it was, so one bad sample does not poison later ones.
    """
    cv = coefficients[0, i]
    ca = coefficients[1, i]
    if not primed[i]:
        ok = True
        for a in range(3):
            ok = ok and math.isfinite(rates[i, a])
        if ok:
            for a in range(3):
                s = state[i, a]
                _reset(rates[i, a], cv, s, 0)
                _reset(0.0, ca, s, 2)
                s[4] = rates[i, a]
            primed[i] = True
    inv_dt = 1.0 / dt_s
    for a in range(3):
        x = rates[i, a]
        if not (primed[i] and math.isfinite(x)):
            rates_out[i, a] = x
            accel_out[i, a] = 0.0 if math.isfinite(x) else np.nan
            continue
        s = state[i, a]
        w = _biquad(x, cv, s, 0)
        accel_out[i, a] = _biquad((w - s[4]) * inv_dt, ca, s, 2)
        s[4] = w
        rates_out[i, a] = w
