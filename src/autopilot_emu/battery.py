"""Battery state estimated from measured voltage and current, as PX4's Battery class does.

The measurements arrive as BATTERY_STATUS from the simulator (a "power module": pack voltage and
current only), like PX4 reads its analog power module. For each vehicle, following PX4's
``src/lib/battery/battery.cpp`` (facts only, re-implemented here for N vehicles at once):

- coulomb counting: ``discharged_mah += I dt / 3.6``;
- voltage-based state of charge: the cell voltage, corrected for the load drop with the internal
  resistance (BAT1_R_INTERNAL, or when negative the recursive-least-squares estimate of
  ``V = OCV - R I`` with forgetting factor 0.95, initial 0.005 ohm per cell, updated only while its
  covariance norm decreases), low-pass filtered (1 s time constant), mapped linearly from
  BAT1_V_EMPTY (0) to BAT1_V_CHARGED (1);
- fusion, once the battery has been connected for 2 s and BAT1_CAPACITY > 0: the estimate moves
  towards the voltage-based one with weight ``0.03 (1 - soc_v)`` per update, then down by the charge
  of this update, and is never above ``1 - discharged / capacity``; without a capacity it is the
  voltage-based estimate.

Not modelled: BAT1_V_LOAD_DROP (superseded in PX4 by BAT1_R_INTERNAL), the remaining-time
estimate, battery scale for thrust compensation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


@dataclass(frozen=True)
class BatteryParams:
    """PX4 BAT1_* parameters of each vehicle, (N,) arrays."""

    n_cells: np.ndarray
    capacity_mah: np.ndarray
    v_empty: np.ndarray
    v_charged: np.ndarray
    r_internal: np.ndarray


class FleetBattery:
    """PX4 battery estimation for N vehicles from measured pack voltage and current."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.voltage_v = np.full(n, np.nan)
        """Last measured pack voltage, V (NaN: never measured)."""
        self.current_a = np.full(n, np.nan)
        """Last measured current, A (NaN: unknown)."""
        self.consumed_mah = np.zeros(n)
        """Charge drawn since the battery was connected, mAh."""
        self.soc = np.full(n, np.nan)
        """Estimated state of charge, 0..1 (NaN: unknown)."""
        self.soc_voltage = np.full(n, np.nan)
        """Voltage-based state of charge, 0..1."""
        self.internal_resistance_ohm = np.full(n, R_DEFAULT_OHM)
        """Per-cell internal resistance estimate, ohm."""
        self.connected_since_s = np.full(n, np.nan)
        self._cell_filter_v = np.full(n, np.nan)
        self._rls = np.zeros((n, 2))  # [OCV, R] of the pack
        self._cov = np.zeros((n, 2, 2))
        self._cov_norm = np.zeros(n)
        self._last_s: float | None = None
        self.params = BatteryParams(
            n_cells=np.full(n, 4.0),
            capacity_mah=np.full(n, -1.0),
            v_empty=np.full(n, 3.6),
            v_charged=np.full(n, 4.05),
            r_internal=np.full(n, -1.0),
        )

    def set_params(self, params: BatteryParams) -> None:
        """New BAT1_* parameters (PX4 needs a reboot for most; here they apply at once)."""
        self.params = params

    @property
    def remaining(self) -> np.ndarray:
        """Estimated state of charge, 0..1, NaN when unknown."""
        return self.soc

    def update(self, voltage_v: np.ndarray, current_a: np.ndarray, time_s: float) -> None:
        """One measurement per vehicle (current NaN or negative: unknown) at ``time_s``."""
        p = self.params
        cells = np.maximum(p.n_cells, 1.0)
        v = np.asarray(voltage_v, dtype=float)
        i = np.asarray(current_a, dtype=float)
        i_known = np.isfinite(i) & (i >= 0.0)
        i_used = np.where(i_known, i, 0.0)
        dt = 0.0 if self._last_s is None else max(time_s - self._last_s, 0.0)
        alpha_dt = min(dt, 2.0)
        self._last_s = time_s

        connected = v >= RECOGNITION_VOLTAGE_V
        fresh = connected & ~np.isfinite(self.connected_since_s)
        self.connected_since_s = np.where(connected, self.connected_since_s, np.nan)
        self.connected_since_s[fresh] = time_s
        if fresh.any():
            self._reset(fresh, v, i_used, cells)
        initialized = connected & (time_s >= self.connected_since_s + INIT_DELAY_S)

        loop_mah = np.where(i_known, i_used * dt / 3.6, 0.0)
        self.consumed_mah += np.where(connected, loop_mah, 0.0)

        self._update_resistance(connected & (i_used > 0.0), v, i_used, cells)
        r_cell = np.where(p.r_internal >= 0.0, p.r_internal, self.internal_resistance_ohm)
        cell_v = v / cells + np.where(i_used > 0.0, r_cell * i_used, 0.0)
        a = alpha_dt / (alpha_dt + VOLTAGE_FILTER_TAU_S)
        filt = self._cell_filter_v + a * (cell_v - self._cell_filter_v)
        self._cell_filter_v = np.where(connected, filt, self._cell_filter_v)
        span = np.maximum(p.v_charged - p.v_empty, 1e-6)
        soc_v = np.clip((self._cell_filter_v - p.v_empty) / span, 0.0, 1.0)
        self.soc_voltage = np.where(connected, soc_v, np.nan)

        capacity = p.capacity_mah
        fuse = initialized & (capacity > 0.0) & np.isfinite(self.soc)
        w = FUSION_GAIN * (1.0 - soc_v)
        safe_cap = np.where(capacity > 0.0, capacity, 1.0)
        fused = (1.0 - w) * self.soc + w * soc_v - loop_mah / safe_cap
        fused = np.minimum(
            np.maximum(fused, 0.0), np.maximum(1.0 - self.consumed_mah / safe_cap, 0.0)
        )
        self.soc = np.where(fuse, fused, np.where(connected, soc_v, np.nan))
        self.voltage_v = np.where(connected, v, np.nan)
        self.current_a = np.where(connected & i_known, i, np.nan)

    def _reset(self, mask: np.ndarray, v: np.ndarray, i: np.ndarray, cells: np.ndarray) -> None:
        """A battery was just connected: restart counting and the estimators (PX4 reset)."""
        self.consumed_mah[mask] = 0.0
        self.internal_resistance_ohm[mask] = R_DEFAULT_OHM
        self._rls[mask, 0] = v[mask]
        self._rls[mask, 1] = R_DEFAULT_OHM * cells[mask]
        self._cov[mask] = 0.0
        self._cov[mask, 0, 0] = OCV_COVARIANCE * cells[mask]
        self._cov[mask, 1, 1] = R_COVARIANCE * cells[mask]
        self._cov_norm[mask] = np.linalg.norm(self._cov[mask], axis=(1, 2))
        r = np.where(self.params.r_internal >= 0.0, self.params.r_internal, R_DEFAULT_OHM)
        self._cell_filter_v[mask] = (v / cells + r * i)[mask]

    def _update_resistance(
        self, mask: np.ndarray, v: np.ndarray, i: np.ndarray, cells: np.ndarray
    ) -> None:
        """PX4's recursive least squares on ``V = OCV - R_pack I``, for the vehicles ``mask``."""
        if not mask.any():
            return
        x = np.stack((np.ones_like(i), -i), axis=1)  # (N, 2)
        px = np.einsum("nij,nj->ni", self._cov, x)
        denom = RLS_LAMBDA + np.einsum("ni,ni->n", x, px)
        gamma = px / denom[:, None]
        error = v - np.einsum("ni,ni->n", x, self._rls)
        rls_new = self._rls + gamma * error[:, None]
        xp = np.einsum("ni,nij->nj", x, self._cov)
        cov_new = (self._cov - gamma[:, :, None] * xp[:, None, :]) / RLS_LAMBDA
        norm_new = np.linalg.norm(cov_new, axis=(1, 2))
        better = mask & (norm_new < self._cov_norm)
        self._rls[better] = rls_new[better]
        self._cov[better] = cov_new[better]
        self._cov_norm[better] = norm_new[better]
        self.internal_resistance_ohm[better] = np.maximum(rls_new[better, 1] / cells[better], 0.0)
        worse = mask & ~better
        self._rls[worse, 0] = (v + self._rls[:, 1] * i)[worse]
