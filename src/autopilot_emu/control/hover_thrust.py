"""Hover-thrust estimator, batched over the fleet: learns MPC_THR_HOVER in flight.

As PX4's mc_hover_thrust_estimator (zero-order hover-thrust EKF): one state, the hover thrust
h, assumed constant (process noise HTE_HT_NOISE). In the air, each navigation tick fuses the
measured vertical acceleration a (up positive) against the model a = g T / h - g, where T is the
upward component of the commanded collective thrust. H = da/dh = -g T / h². Measurements
failing the innovation gate (HTE_ACC_GATE standard deviations) are rejected; a persistent
one-sided rejection (low-passed signed test ratio > 0.2) inflates the variance so the filter can
follow a sudden change. The acceleration noise variance is learned from the de-biased residual
(bounded to 1..400 (m/s²)²). Above HTE_VXY_THR / HTE_VZ_THR the measurement noise grows linearly
with speed (drag and prop wash bias the model). The estimate is bounded to MPC_THR_HOVER ±
HTE_THR_RANGE (and 0.1..0.9), and becomes *valid* once its variance stays below 0.001 for 2 s;
disarmed, it restarts from MPC_THR_HOVER with the standard deviation HTE_HT_ERR_INIT.

The acceleration comes from the autopilot's own estimate, never from simulator truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

G_M_S2 = 9.80665
_ACC_VAR_INIT = 5.0
"""Initial acceleration noise variance, (m/s²)²."""
_ACC_VAR_MIN, _ACC_VAR_MAX = 1.0, 400.0
_LPF_TAU_S = 1.0
"""Time constant of the residual and signed-test-ratio low-pass filters, s."""
_NOISE_TAU_S = 2.0
"""Time constant of the acceleration-noise learning, s."""
_VALID_VAR = 1e-3
_VALID_HOLD_S = 2.0


def _clip(x: np.ndarray, lo: np.ndarray | float, hi: np.ndarray | float) -> np.ndarray:
    """np.clip without its per-call overhead (it dominates on (N,) arrays of a few vehicles)."""
    return np.minimum(np.maximum(x, lo), hi)


@dataclass
class HoverThrustParams:
    """Per-vehicle HTE_* and MPC_THR_HOVER values, (N,) arrays."""

    initial: np.ndarray
    """MPC_THR_HOVER: the starting guess, normalised thrust."""
    process_noise: np.ndarray
    """HTE_HT_NOISE, normalised thrust / s."""
    gate: np.ndarray
    """HTE_ACC_GATE, standard deviations."""
    error_init: np.ndarray
    """HTE_HT_ERR_INIT, 1-sigma, normalised thrust."""
    vxy_threshold_m_s: np.ndarray
    """HTE_VXY_THR."""
    vz_threshold_m_s: np.ndarray
    """HTE_VZ_THR."""
    range: np.ndarray
    """HTE_THR_RANGE: largest deviation of the estimate from MPC_THR_HOVER."""


class HoverThrustEstimator:
    """One-state Kalman filter on the hover thrust of each of N vehicles."""

    def __init__(self, params: HoverThrustParams) -> None:
        n = len(params.initial)
        self.params = params
        self.hover_thrust = params.initial.copy()
        self.variance = params.error_init**2
        self.acc_variance = np.full(n, _ACC_VAR_INIT)
        self.residual_lpf = np.zeros(n)
        self.ratio_lpf = np.zeros(n)
        self.valid = np.zeros(n, dtype=bool)
        self._good_for_s = np.zeros(n)

    def set_params(self, params: HoverThrustParams) -> None:
        """New parameters; a changed initial uncertainty resets the variance (as PX4)."""
        changed = params.error_init != self.params.error_init
        self.variance = np.where(changed, params.error_init**2, self.variance)
        self.params = params

    def reset(self, mask: np.ndarray) -> None:
        """Back to MPC_THR_HOVER with HTE_HT_ERR_INIT (on the ground, disarmed)."""
        p = self.params
        self.hover_thrust[mask] = p.initial[mask]
        self.variance[mask] = p.error_init[mask] ** 2
        self.acc_variance[mask] = _ACC_VAR_INIT
        self.residual_lpf[mask] = 0.0
        self.ratio_lpf[mask] = 0.0
        self.valid[mask] = False
        self._good_for_s[mask] = 0.0

    def update(
        self,
        active: np.ndarray,
        acc_up_m_s2: np.ndarray,
        thrust_up: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        dt_s: float,
    ) -> None:
        """Predict and fuse one sample for the ``active`` (armed, in the air) vehicles."""
        if not active.any():
            self.valid &= active
            self._good_for_s[~active] = 0.0
            return
        p = self.params
        h = self.hover_thrust
        var = self.variance + (p.process_noise * dt_s) ** 2
        speed_xy = np.hypot(velocity_ned_m_s[:, 0], velocity_ned_m_s[:, 1])
        scale = np.maximum(
            np.maximum(
                speed_xy - p.vxy_threshold_m_s, np.abs(velocity_ned_m_s[:, 2]) - p.vz_threshold_m_s
            )
            + 1.0,
            1.0,
        )
        r = self.acc_variance * scale * scale
        jac = -G_M_S2 * thrust_up / (h * h)
        innov_var = np.maximum(jac * var * jac + r, r)
        innov = acc_up_m_s2 - (G_M_S2 * thrust_up / h - G_M_S2)
        ratio = innov * innov / (p.gate * p.gate * innov_var)
        gain = var * jac / innov_var
        passing = ratio < 1.0
        lo = _clip(p.initial - p.range, 0.0, 0.8)
        hi = _clip(p.initial + p.range, 0.2, 0.9)
        h_new = np.where(passing, _clip(h + gain * innov, np.maximum(lo, 0.1), hi), h)
        var_new = np.where(passing, _clip((1.0 - gain * jac) * var, 1e-10, 1.0), var)
        bump = ~passing & (np.abs(self.ratio_lpf) > 0.2)
        var_new = np.where(bump, var_new + 1e3 * (p.process_noise**2) * dt_s, var_new)
        residual = np.where(passing, acc_up_m_s2 - (G_M_S2 * thrust_up / h_new - G_M_S2), innov)
        alpha = dt_s / (_LPF_TAU_S + dt_s)
        res_lpf = self.residual_lpf + alpha * (residual - self.residual_lpf)
        signed = _clip(np.sign(innov) * ratio, -1.0, 1.0)
        ratio_lpf = self.ratio_lpf + alpha * (signed - self.ratio_lpf)
        beta = dt_s / (_NOISE_TAU_S + dt_s)
        unbiased = residual - res_lpf
        acc_var = _clip(
            (1.0 - beta) * self.acc_variance + beta * (unbiased * unbiased + jac * var_new * jac),
            _ACC_VAR_MIN,
            _ACC_VAR_MAX,
        )
        if active.all():
            self.hover_thrust, self.variance, self.acc_variance = h_new, var_new, acc_var
            self.residual_lpf, self.ratio_lpf = res_lpf, ratio_lpf
        else:
            self.hover_thrust = np.where(active, h_new, h)
            self.variance = np.where(active, var_new, self.variance)
            self.acc_variance = np.where(active, acc_var, self.acc_variance)
            self.residual_lpf = np.where(active, res_lpf, self.residual_lpf)
            self.ratio_lpf = np.where(active, ratio_lpf, self.ratio_lpf)
        good = active & (self.variance < _VALID_VAR) & (self.valid | passing)
        self._good_for_s = np.where(good, self._good_for_s + dt_s, 0.0)
        self.valid = good & (self.valid | (self._good_for_s >= _VALID_HOLD_S))
