"""Compiled control allocation: torque and collective thrust -> motor outputs, one row each.

Compiled into the inner loop's kernel (:mod:`autopilot_emu.control.inner_loop_kernel`), with the
allocation of :class:`autopilot_emu.control.mixer.Mixer`. Per vehicle: its thrust fractions first;
if one of them leaves 0..1 (and none is NaN), the vehicle's outputs are desaturated (roll/pitch kept
by shifting the collective thrust, yaw scaled into what is left); then each fraction goes through
PX4's thrust model (THR_MDL_FAC) to an output, floored at idle on used rotors, 0 elsewhere.
Vehicles never affect each other (an earlier version decided saturation for the whole fleet at
once, which coupled them).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def fractions_row(
    i: int, torque: np.ndarray, thrust: np.ndarray, matrix: np.ndarray,
    thrust_column: np.ndarray, out: np.ndarray,
) -> bool:  # fmt: skip
    """Vehicle i's unsaturated thrust fractions into ``out[i]``; True when it needs desaturation.

    Each vehicle is mixed on its own, as each PX4 instance mixes its own outputs: one vehicle's
    saturation never touches another's outputs.
    """
    hi, lo, nan = -np.inf, np.inf, False
    t0, t1, t2, thr = torque[i, 0], torque[i, 1], torque[i, 2], thrust[i]
    for r in range(out.shape[1]):
        m = matrix[i, r]
        f = thr * thrust_column[i, r] + (m[0] * t0 + m[1] * t1 + m[2] * t2)
        out[i, r] = f
        if f != f:
            nan = True
        elif f > hi:
            hi = f
        if f < lo:
            lo = f
    return not nan and (hi > 1.0 or lo < 0.0)


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def desaturate_row(
    i: int, torque: np.ndarray, thrust: np.ndarray, matrix: np.ndarray,
    thrust_column: np.ndarray, used: np.ndarray, out: np.ndarray,
) -> None:  # fmt: skip
    """Keep roll/pitch by shifting collective thrust, then scale yaw into what is left."""
    m_rotors = out.shape[1]
    thr = np.empty(m_rotors)
    t_rp = np.empty(m_rotors)
    t_y = np.empty(m_rotors)
    hi, lo = -np.inf, np.inf
    for r in range(m_rotors):
        thr[r] = thrust[i] * thrust_column[i, r]
        t_y[r] = matrix[i, r, 2] * torque[i, 2]
        t_rp[r] = out[i, r] - thr[r] - t_y[r]
        if used[i, r]:
            base = thr[r] + t_rp[r]
            hi = fmax(hi, base)
            lo = fmin(lo, base)
    shift = -fmax(hi - 1.0, 0.0) + fmax(-lo, 0.0)
    k = np.inf
    for r in range(m_rotors):
        base = thr[r] + shift + t_rp[r] if used[i, r] else 0.0
        thr[r] = base
        ty = t_y[r]
        room_up = (1.0 - base) / fmax(ty, 1e-9) if ty > 0 else np.inf
        room_dn = base / fmax(-ty, 1e-9) if ty < 0 else np.inf
        k = fmin(k, fmin(room_up, room_dn))
    k = fmin(fmax(k, 0.0), 1.0)
    for r in range(m_rotors):
        out[i, r] = fmin(fmax(thr[r] + k * t_y[r], 0.0), 1.0)


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def output_row(
    i: int, used: np.ndarray, idle_output: float, thrust_model_factor: np.ndarray, out: np.ndarray
) -> None:
    """Thrust fractions -> motor outputs, idle floor, unused outputs 0.

    PX4's thrust model (mixer_module FunctionMotors): relative thrust = a u² + (1 - a) u with
    a = THR_MDL_FAC; for 0 < a <= 1 the output is the positive root, otherwise (PX4's default
    a = 0) the output is the fraction itself.
    """
    a = thrust_model_factor[i]
    shaped = 0.0 < a <= 1.0
    half_b = (1.0 - a) / (2.0 * a) if shaped else 0.0
    for r in range(out.shape[1]):
        f = out[i, r]
        if shaped and f > 0.0:
            f = math.sqrt(half_b * half_b + f / a) - half_b
        elif shaped and f <= 0.0:
            f = 0.0  # NaN stays NaN (fmax keeps it), as numpy would
        used_f = 1.0 if used[i, r] else 0.0
        out[i, r] = fmax(f, idle_output) * used_f
