"""Hover-thrust estimator loop, batched over the fleet: learns MPC_THR_HOVER in flight.

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

The hover thrust the position controller uses is the last valid estimate since arming, else
MPC_THR_HOVER; when it changes, the vertical velocity integrator absorbs the change so the
thrust stays continuous (as PX4's updateHoverThrust). The acceleration comes from the autopilot's
own estimate, never from simulator truth. One entry point, :meth:`HoverThrustLoop.step`, runs
``hover_thrust_kernel.hover_thrust_tick_kernel`` for the fleet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from autopilot_emu.control.hover_thrust_kernel import (
    ACC_VAR_INIT,
    G_M_S2,
    hover_thrust_tick_kernel,
)
from autopilot_emu.params import ParamStore, param_column

__all__ = ["G_M_S2", "HoverThrustLoop", "HoverThrustParams", "HoverThrustState"]


@dataclass(frozen=True)
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
    """HTE_VXY_THR, m/s."""
    vz_threshold_m_s: np.ndarray
    """HTE_VZ_THR, m/s."""
    range: np.ndarray
    """HTE_THR_RANGE: largest deviation of the estimate from MPC_THR_HOVER."""

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> HoverThrustParams:
        """Read the parameters of every vehicle."""
        return cls(
            initial=param_column(params, "MPC_THR_HOVER"),
            process_noise=param_column(params, "HTE_HT_NOISE"),
            gate=param_column(params, "HTE_ACC_GATE"),
            error_init=param_column(params, "HTE_HT_ERR_INIT"),
            vxy_threshold_m_s=param_column(params, "HTE_VXY_THR"),
            vz_threshold_m_s=param_column(params, "HTE_VZ_THR"),
            range=param_column(params, "HTE_THR_RANGE"),
        )


@dataclass
class HoverThrustState:
    """The estimator of every vehicle and the hover thrust handed on, (N,) arrays."""

    estimate: np.ndarray
    """Hover-thrust estimate, normalised thrust."""
    variance: np.ndarray
    """Its variance, (normalised thrust)²."""
    acc_variance: np.ndarray
    """Learned acceleration noise variance, (m/s²)²."""
    residual_lpf: np.ndarray
    """Low-passed acceleration residual, m/s²."""
    ratio_lpf: np.ndarray
    """Low-passed signed innovation test ratio."""
    valid: np.ndarray
    """The estimate is valid (its variance small for long enough)."""
    good_for_s: np.ndarray
    """How long the variance has been small, s."""
    learned: np.ndarray
    """The estimate has been valid since arming: ``in_use`` is learned."""
    in_use: np.ndarray
    """Hover thrust the position controller uses: the last valid estimate since arming, else
    MPC_THR_HOVER; 0 before the first parameters."""

    @classmethod
    def zeros(cls, n: int) -> HoverThrustState:
        """State of n vehicles before any parameters."""
        return cls(
            estimate=np.zeros(n),
            variance=np.zeros(n),
            acc_variance=np.full(n, ACC_VAR_INIT),
            residual_lpf=np.zeros(n),
            ratio_lpf=np.zeros(n),
            valid=np.zeros(n, dtype=bool),
            good_for_s=np.zeros(n),
            learned=np.zeros(n, dtype=bool),
            in_use=np.zeros(n),
        )


class HoverThrustLoop:
    """One-state Kalman filter on the hover thrust of each of N vehicles, at the nav rate."""

    def __init__(self, n: int) -> None:
        self.state = HoverThrustState.zeros(n)
        self.params: HoverThrustParams | None = None
        """Set by :meth:`set_params` before the first step."""

    def set_params(self, params: HoverThrustParams) -> None:
        """New parameters (the first start the estimator), as PX4.

        A changed initial uncertainty resets the variance; a hover thrust not yet in use starts
        at MPC_THR_HOVER.
        """
        s, old = self.state, self.params
        if old is None:
            s.estimate[:] = params.initial
            s.variance[:] = params.error_init**2
        else:
            np.copyto(s.variance, params.error_init**2, where=params.error_init != old.error_init)
        self.params = params
        if not s.in_use.any():
            s.in_use[:] = params.initial

    def step(
        self,
        *,
        flying: np.ndarray,
        armed: np.ndarray,
        accel_ned_m_s2: np.ndarray,
        thrust: np.ndarray,
        rotation: np.ndarray,
        velocity_ned_m_s: np.ndarray,
        dt_s: float,
        velocity_integral: np.ndarray,
    ) -> None:
        """Fuse one sample per vehicle; update the hover thrust in use (``state.in_use``).

        ``flying`` (N,) vehicles in the air past take-off; ``armed`` (N,), disarmed ones restart.
        Estimated acceleration and velocity NED (N, 3), m/s² and m/s; the last collective thrust
        command (N,) 0..1 and the attitude ``rotation`` (N, 3, 3) body -> NED give its upward
        part. ``velocity_integral`` (N, 3), m/s², is the position controller's: its vertical
        axis absorbs a change of the hover thrust in use.
        """
        p, s = self.params, self.state
        assert p is not None, "set_params first"
        hover_thrust_tick_kernel(
            flying, armed, accel_ned_m_s2, thrust, rotation, velocity_ned_m_s, dt_s, p.initial,
            p.process_noise, p.gate, p.error_init, p.range, p.vxy_threshold_m_s,
            p.vz_threshold_m_s, s.estimate, s.variance, s.acc_variance, s.residual_lpf,
            s.ratio_lpf, s.valid, s.good_for_s, s.learned, s.in_use, velocity_integral,
        )  # fmt: skip
