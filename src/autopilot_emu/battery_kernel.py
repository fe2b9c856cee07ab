"""Compiled battery estimation step (see :mod:`autopilot_emu.battery` for the method).

One call per BATTERY_STATUS batch updates every vehicle's coulomb count, internal-resistance
estimate (recursive least squares), filtered cell voltage and fused state of charge in place.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from autopilot_emu.nan_scalar import fmax, fmin

RECOGNITION_VOLTAGE_V = 2.1
"""Below this pack voltage no battery is connected (PX4 LITHIUM_BATTERY_RECOGNITION_VOLTAGE)."""
INIT_DELAY_S = 2.0
"""Connected time before the estimate fuses coulomb counting, s (PX4)."""
VOLTAGE_FILTER_TAU_S = 1.0
"""Time constant of the cell-voltage low-pass filter, s (PX4)."""
RLS_LAMBDA = 0.95
"""Forgetting factor of the internal-resistance estimator (PX4 LAMBDA)."""
R_DEFAULT_OHM = 0.005
"""Initial per-cell internal resistance estimate, ohm (PX4 R_DEFAULT)."""
OCV_COVARIANCE = 1.5
"""Initial per-cell covariance of the open-circuit voltage (PX4)."""
R_COVARIANCE = 0.1
"""Initial per-cell covariance of the internal resistance (PX4)."""
FUSION_GAIN = 3e-2
"""Weight of the voltage-based estimate per update, times (1 - soc_v) (PX4)."""


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _reset_row(
    i: int, v: float, cur: float, cells: float, r_internal: float, consumed_mah: np.ndarray,
    resistance: np.ndarray, rls: np.ndarray, cov: np.ndarray, cov_norm: np.ndarray,
    cell_filter_v: np.ndarray,
) -> None:  # fmt: skip
    """A battery was just connected: restart counting and the estimators (PX4 reset)."""
    consumed_mah[i] = 0.0
    resistance[i] = R_DEFAULT_OHM
    rls[i, 0] = v
    rls[i, 1] = R_DEFAULT_OHM * cells
    c00, c11 = OCV_COVARIANCE * cells, R_COVARIANCE * cells
    cov[i, 0, 0], cov[i, 0, 1], cov[i, 1, 0], cov[i, 1, 1] = c00, 0.0, 0.0, c11
    cov_norm[i] = math.sqrt(c00 * c00 + c11 * c11)
    r = r_internal if r_internal >= 0.0 else R_DEFAULT_OHM
    cell_filter_v[i] = v / cells + r * cur


@numba.njit(cache=True, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _resistance_row(
    i: int, v: float, cur: float, cells: float, resistance: np.ndarray, rls: np.ndarray,
    cov: np.ndarray, cov_norm: np.ndarray,
) -> None:  # fmt: skip
    """PX4's recursive least squares on ``V = OCV - R_pack I``; kept only while it converges."""
    x0, x1 = 1.0, -cur
    c = cov[i]
    px0 = c[0, 0] * x0 + c[0, 1] * x1
    px1 = c[1, 0] * x0 + c[1, 1] * x1
    denom = RLS_LAMBDA + (x0 * px0 + x1 * px1)
    g0, g1 = px0 / denom, px1 / denom
    error = v - (x0 * rls[i, 0] + x1 * rls[i, 1])
    xp0 = x0 * c[0, 0] + x1 * c[1, 0]
    xp1 = x0 * c[0, 1] + x1 * c[1, 1]
    n00 = (c[0, 0] - g0 * xp0) / RLS_LAMBDA
    n01 = (c[0, 1] - g0 * xp1) / RLS_LAMBDA
    n10 = (c[1, 0] - g1 * xp0) / RLS_LAMBDA
    n11 = (c[1, 1] - g1 * xp1) / RLS_LAMBDA
    norm = math.sqrt(n00 * n00 + n01 * n01 + n10 * n10 + n11 * n11)
    if norm < cov_norm[i]:
        rls[i, 0] += g0 * error
        rls[i, 1] += g1 * error
        c[0, 0], c[0, 1], c[1, 0], c[1, 1] = n00, n01, n10, n11
        cov_norm[i] = norm
        resistance[i] = fmax(rls[i, 1] / cells, 0.0)
    else:
        rls[i, 0] = v + rls[i, 1] * cur


@numba.njit(cache=True, error_model="numpy")
def battery_kernel(
    voltage_v: np.ndarray, current_a: np.ndarray, time_s: float, dt_s: float,
    n_cells: np.ndarray, capacity_mah: np.ndarray, v_empty: np.ndarray,
    v_charged: np.ndarray, r_internal: np.ndarray,
    voltage_out: np.ndarray, current_out: np.ndarray, consumed_mah: np.ndarray,
    soc: np.ndarray, soc_voltage: np.ndarray, resistance: np.ndarray,
    connected_since_s: np.ndarray, cell_filter_v: np.ndarray, rls: np.ndarray,
    cov: np.ndarray, cov_norm: np.ndarray,
) -> None:  # fmt: skip
    """One measurement per vehicle (current NaN or negative: unknown), ``dt_s`` after the last."""
    alpha_dt = fmin(dt_s, 2.0)
    a = alpha_dt / (alpha_dt + VOLTAGE_FILTER_TAU_S)
    for i in range(voltage_v.shape[0]):
        cells = fmax(n_cells[i], 1.0)
        v, cur = voltage_v[i], current_a[i]
        i_known = math.isfinite(cur) and cur >= 0.0
        i_used = cur if i_known else 0.0
        connected = v >= RECOGNITION_VOLTAGE_V
        if not connected:
            connected_since_s[i] = np.nan
        elif not math.isfinite(connected_since_s[i]):
            connected_since_s[i] = time_s
            _reset_row(
                i, v, i_used, cells, r_internal[i], consumed_mah, resistance, rls, cov,
                cov_norm, cell_filter_v,
            )  # fmt: skip
        initialized = connected and time_s >= connected_since_s[i] + INIT_DELAY_S
        loop_mah = i_used * dt_s / 3.6 if i_known else 0.0
        if connected:
            consumed_mah[i] += loop_mah
            if i_used > 0.0:
                _resistance_row(i, v, i_used, cells, resistance, rls, cov, cov_norm)
        r_cell = r_internal[i] if r_internal[i] >= 0.0 else resistance[i]
        cell_v = v / cells + (r_cell * i_used if i_used > 0.0 else 0.0)
        if connected:
            cell_filter_v[i] = cell_filter_v[i] + a * (cell_v - cell_filter_v[i])
        span = fmax(v_charged[i] - v_empty[i], 1e-6)
        soc_v = fmin(fmax((cell_filter_v[i] - v_empty[i]) / span, 0.0), 1.0)
        soc_voltage[i] = soc_v if connected else np.nan
        capacity = capacity_mah[i]
        if initialized and capacity > 0.0 and math.isfinite(soc[i]):
            w = FUSION_GAIN * (1.0 - soc_v)
            fused = (1.0 - w) * soc[i] + w * soc_v - loop_mah / capacity
            cap_left = fmax(1.0 - consumed_mah[i] / capacity, 0.0)
            soc[i] = fmin(fmax(fused, 0.0), cap_left)
        else:
            soc[i] = soc_v if connected else np.nan
        voltage_out[i] = v if connected else np.nan
        current_out[i] = cur if (connected and i_known) else np.nan
