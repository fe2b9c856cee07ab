"""A LiPo pack: open-circuit voltage vs state of charge, series resistance, sag under load.

Cell open-circuit voltage (Chen and Rincon-Mora 2006, "Accurate electrical battery model capable
of predicting runtime and I-V performance", IEEE Trans. Energy Conversion 21(2):504-511, Eq. for
V_OC(SOC) fitted to a lithium-ion polymer cell)::

    V_oc(s) = -1.031 exp(-35 s) + 3.685 + 0.2156 s - 0.1178 s^2 + 0.3201 s^3      [V, s in 0..1]

which runs from 2.65 V (empty) through 3.80 V (half) to 4.10 V (full). The pack is ``cells``
such cells in series with a series resistance ``cells * cell_internal_resistance_ohm``. A load of
power P draws the current that solves ``P = (V_oc - R I) I`` (terminal voltage times current):

    I = (V_oc - sqrt(V_oc^2 - 4 R P)) / (2 R)

and beyond the pack's maximum power ``V_oc^2 / (4 R)`` the current saturates at ``V_oc / (2 R)``.
Charge is counted in simulation time (``ds = -I dt / capacity``). Not modelled: the RC transient
of the Chen model (seconds), temperature, ageing, Peukert capacity loss.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

_OCV_A, _OCV_B = -1.031, -35.0
_OCV_POLY = (3.685, 0.2156, -0.1178, 0.3201)


def cell_ocv_v(soc: np.ndarray | float) -> np.ndarray:
    """Open-circuit voltage of one cell at state of charge ``soc`` (0..1), V (Chen 2006)."""
    s = np.minimum(np.maximum(soc, 0.0), 1.0)  # (np.clip is slow on small arrays)
    c0, c1, c2, c3 = _OCV_POLY
    return _OCV_A * np.exp(_OCV_B * s) + (c0 + s * (c1 + s * (c2 + s * c3)))


_OCV_TABLE_SOC = np.linspace(0.0, 1.0, 2001)
_OCV_TABLE_V = cell_ocv_v(_OCV_TABLE_SOC)
"""The cell OCV curve tabulated every 0.05 % of charge: one np.interp per update in the hot loop
(linear interpolation error < 0.05 mV, where the exponential term curves most)."""


@dataclass(frozen=True)
class LipoParams:
    """A LiPo pack (the ``power.battery`` block of an airframe YAML)."""

    cells: int
    """Cells in series."""
    capacity_mah: float
    """Rated capacity, mAh."""
    cell_internal_resistance_ohm: float
    """Series resistance of one cell, ohm."""
    cutoff_cell_v: float
    """Loaded cell voltage at which the ESCs' low-voltage cutoff stops the motors, V."""

    def __post_init__(self) -> None:
        if isinstance(self.cells, bool) or not isinstance(self.cells, int) or self.cells < 1:
            raise ValueError(f"battery cells must be an int >= 1, got {self.cells!r}")
        for name in ("capacity_mah", "cell_internal_resistance_ohm", "cutoff_cell_v"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"battery {name} must be positive, got {getattr(self, name)!r}")

    @property
    def resistance_ohm(self) -> float:
        """Series resistance of the pack, ohm."""
        return self.cells * self.cell_internal_resistance_ohm

    @property
    def capacity_c(self) -> float:
        """Capacity, coulomb."""
        return self.capacity_mah * 3.6

    @property
    def cutoff_v(self) -> float:
        """Pack voltage of the low-voltage cutoff, V."""
        return self.cells * self.cutoff_cell_v

    def ocv_v(self, soc: np.ndarray | float) -> np.ndarray:
        """Open-circuit pack voltage at state of charge ``soc``, V (tabulated: < 0.1 mV/cell)."""
        return np.interp(soc, _OCV_TABLE_SOC, _OCV_TABLE_V) * self.cells

    def current_a(self, soc: np.ndarray, power_w: np.ndarray) -> np.ndarray:
        """Current that delivers ``power_w`` at the terminals (saturating at max power), A."""
        ocv = self.ocv_v(soc)
        r = self.resistance_ohm
        disc = np.maximum(ocv * ocv - 4.0 * r * np.maximum(power_w, 0.0), 0.0)
        return (ocv - np.sqrt(disc)) / (2.0 * r)


class LipoPack:
    """State of charge, current and terminal voltage of N packs, integrated in simulation time."""

    def __init__(
        self,
        params: LipoParams,
        n: int,
        soc: float = 1.0,
        capacity_mah: Sequence[float] | np.ndarray | None = None,
    ) -> None:
        if not 0.0 <= soc <= 1.0:
            raise ValueError(f"initial state of charge must be in [0, 1], got {soc}")
        self.params = params
        if capacity_mah is None:
            capacity_mah = np.full(n, params.capacity_mah)
        capacity = np.array(capacity_mah, dtype=float).reshape(-1)
        if capacity.shape != (n,) or not (capacity > 0.0).all():
            raise ValueError(f"capacity_mah must be {n} positive values, got {capacity_mah!r}")
        self.capacity_mah = capacity
        """Capacity of each pack, mAh, (N,) (the params' unless given: packs of other sizes)."""
        self._inv_capacity_c = 1.0 / (capacity * 3.6)
        self.soc = np.full(n, float(soc))
        """State of charge, 0..1, (N,)."""
        self.current_a = np.zeros(n)
        """Current drawn, A, (N,)."""
        self.ocv_v = params.ocv_v(self.soc)
        """Open-circuit voltage at the present state of charge, V, (N,)."""
        self.voltage_v = self.ocv_v.copy()
        """Terminal voltage under the present load, V, (N,)."""
        self.cut_off = np.zeros(n, dtype=bool)
        """The low-voltage cutoff has tripped (latched until a new pack): no power, (N,)."""

    def draw(self, power_w: np.ndarray, dt_s: float) -> None:
        """Deliver ``power_w`` (N,) for ``dt_s``: update current, charge and terminal voltage."""
        p = self.params
        r = p.resistance_ohm
        ocv = self.ocv_v
        power = np.where(self.cut_off, 0.0, power_w) if self.cut_off.any() else power_w
        disc = np.maximum(ocv * ocv - (4.0 * r) * power, 0.0)
        current = (ocv - np.sqrt(disc)) * (0.5 / r)
        self.soc = np.maximum(self.soc - current * (dt_s * self._inv_capacity_c), 0.0)
        self.ocv_v = p.ocv_v(self.soc)
        self.current_a = current
        self.voltage_v = self.ocv_v - current * r
        self.cut_off |= self.voltage_v < p.cutoff_v


def endurance_s(params: LipoParams, power_w: float, dt_s: float = 1.0, soc: float = 1.0) -> float:
    """Time a full pack delivers a constant ``power_w`` until the loaded voltage reaches cutoff, s.

    Integrates :class:`LipoPack` (the same model the simulation uses) at ``dt_s`` steps and
    interpolates the crossing; ``inf`` for a non-positive power.
    """
    if not power_w > 0.0:
        return float("inf")
    pack = LipoPack(params, 1, soc)
    power = np.array([float(power_w)])
    t = 0.0
    soc0 = np.array([float(soc)])
    v_prev = float(params.ocv_v(soc0)[0] - params.current_a(soc0, power)[0] * params.resistance_ohm)
    while True:
        pack.draw(power, dt_s)
        v = float(pack.voltage_v[0])
        if pack.cut_off[0]:
            frac = (v_prev - params.cutoff_v) / max(v_prev - v, 1e-12)
            return t + min(max(frac, 0.0), 1.0) * dt_s
        t += dt_s
        v_prev = v
        if pack.soc[0] <= 0.0:
            return t


def endurance_to_reserve_s(
    params: LipoParams, power_w: float, reserve_soc: float, dt_s: float = 1.0, soc: float = 1.0
) -> float:
    """Time a full pack delivers a constant ``power_w`` until ``reserve_soc`` of it is left, s.

    The reserve is a fraction of the rated capacity, as PX4's BAT_LOW_THR (its remaining-charge
    estimate never exceeds ``1 - discharged / capacity``). Integrates :class:`LipoPack` at
    ``dt_s`` steps and interpolates the crossing; stops earlier if the low-voltage cutoff trips
    first (a pack too weak for the load); ``inf`` for a non-positive power.
    """
    if not 0.0 <= reserve_soc < 1.0:
        raise ValueError(f"reserve_soc must be in [0, 1), got {reserve_soc!r}")
    if not power_w > 0.0:
        return float("inf")
    if soc <= reserve_soc:
        return 0.0
    pack = LipoPack(params, 1, soc)
    power = np.array([float(power_w)])
    t = 0.0
    while True:
        soc_prev = float(pack.soc[0])
        pack.draw(power, dt_s)
        soc_now = float(pack.soc[0])
        if soc_now <= reserve_soc:
            return t + (soc_prev - reserve_soc) / max(soc_prev - soc_now, 1e-15) * dt_s
        t += dt_s
        if pack.cut_off[0]:
            return t
