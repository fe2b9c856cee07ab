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

from autopilot_emu.battery_kernel import (
    FUSION_GAIN,
    INIT_DELAY_S,
    OCV_COVARIANCE,
    R_COVARIANCE,
    R_DEFAULT_OHM,
    RECOGNITION_VOLTAGE_V,
    RLS_LAMBDA,
    VOLTAGE_FILTER_TAU_S,
    battery_kernel,
)
from autopilot_emu.params import ParamStore, param_column

__all__ = [
    "FUSION_GAIN",
    "INIT_DELAY_S",
    "OCV_COVARIANCE",
    "RECOGNITION_VOLTAGE_V",
    "RLS_LAMBDA",
    "R_COVARIANCE",
    "R_DEFAULT_OHM",
    "VOLTAGE_FILTER_TAU_S",
    "BatteryParams",
    "FleetBattery",
]


@dataclass(frozen=True)
class BatteryParams:
    """PX4 BAT1_* parameters of each vehicle, (N,) arrays."""

    n_cells: np.ndarray
    capacity_mah: np.ndarray
    v_empty: np.ndarray
    v_charged: np.ndarray
    r_internal: np.ndarray

    @classmethod
    def from_params(cls, params: list[ParamStore]) -> BatteryParams:
        """Read the parameters of every vehicle."""
        return cls(
            n_cells=param_column(params, "BAT1_N_CELLS"),
            capacity_mah=param_column(params, "BAT1_CAPACITY"),
            v_empty=param_column(params, "BAT1_V_EMPTY"),
            v_charged=param_column(params, "BAT1_V_CHARGED"),
            r_internal=param_column(params, "BAT1_R_INTERNAL"),
        )


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
        self._packed_for: BatteryParams | None = None
        self._packed: tuple[np.ndarray, ...] = ()
        """The parameters as C-contiguous float64 arrays, for ``_packed_for``."""
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
        """One measurement per vehicle (current NaN or negative: unknown) at ``time_s``.

        Compiled (``battery_kernel``); the state arrays are updated in place.
        """
        p = self.params
        if self._packed_for is not p:  # convert once per parameter set, not per sample
            self._packed = tuple(
                _f64(a) for a in (p.n_cells, p.capacity_mah, p.v_empty, p.v_charged, p.r_internal)
            )
            self._packed_for = p
        n_cells, capacity_mah, v_empty, v_charged, r_internal = self._packed
        dt = 0.0 if self._last_s is None else max(time_s - self._last_s, 0.0)
        self._last_s = time_s
        battery_kernel(
            _f64(voltage_v), _f64(current_a), float(time_s), dt, n_cells,
            capacity_mah, v_empty, v_charged, r_internal,
            self.voltage_v, self.current_a, self.consumed_mah, self.soc, self.soc_voltage,
            self.internal_resistance_ohm, self.connected_since_s, self._cell_filter_v,
            self._rls, self._cov, self._cov_norm,
        )  # fmt: skip


def _f64(a: np.ndarray) -> np.ndarray:
    """C-contiguous float64 (one compiled signature for the kernel)."""
    return np.ascontiguousarray(a, dtype=np.float64)
