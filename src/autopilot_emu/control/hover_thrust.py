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

from autopilot_emu.control.hover_thrust_kernel import (
    ACC_VAR_INIT,
    G_M_S2,
    hover_thrust_kernel,
    reset_kernel,
)

__all__ = ["G_M_S2", "HoverThrustEstimator", "HoverThrustParams"]


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
        self.variance = np.asarray(params.error_init, dtype=np.float64) ** 2
        self.acc_variance = np.full(n, ACC_VAR_INIT)
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
        reset_kernel(
            np.asarray(mask, dtype=np.bool_), _f64(p.initial), _f64(p.error_init),
            self.hover_thrust, self.variance, self.acc_variance, self.residual_lpf,
            self.ratio_lpf, self.valid, self._good_for_s,
        )  # fmt: skip

    def update(
        self,
        active: np.ndarray,
        acc_up_m_s2: np.ndarray,
        thrust_up: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        dt_s: float,
    ) -> None:
        """Predict and fuse one sample for the ``active`` (armed, in the air) vehicles.

        Compiled (``hover_thrust_kernel``); the state arrays are updated in place.
        """
        p = self.params
        hover_thrust_kernel(
            np.asarray(active, dtype=np.bool_), _f64(acc_up_m_s2), _f64(thrust_up),
            _f64(velocity_ned_m_s), float(dt_s), _f64(p.initial), _f64(p.process_noise),
            _f64(p.gate), _f64(p.range), _f64(p.vxy_threshold_m_s), _f64(p.vz_threshold_m_s),
            self.hover_thrust, self.variance, self.acc_variance, self.residual_lpf,
            self.ratio_lpf, self.valid, self._good_for_s,
        )  # fmt: skip


def _f64(a: np.ndarray) -> np.ndarray:
    """C-contiguous float64 (one compiled signature for the kernels)."""
    return np.ascontiguousarray(a, dtype=np.float64)
