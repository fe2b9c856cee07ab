"""Batteries of kinematic vehicles: hover rotor power while airborne, plus loads, from LiPo packs.

The swarm-scale engine's vehicles have no rotors. Each draws, every kinematic step ``dt``, the
electrical power ``P = P_hover (while airborne) + P_loads`` from its own :class:`LipoPack` (its
airframe's pack parameters, its own capacity), where ``P_hover`` is the momentum-theory hover
power of its airframe (:meth:`sitl.power.propulsion.PropulsionParams.hover_power_w`). Forward
flight and climb are not modelled (docs/swarm.md, "Energy and battery", gives the size of that
error). A kinematic vehicle has no motors to stop: when a pack's loaded voltage falls under the
cutoff, the time is recorded (``cutoff_at_s``) and the drain goes on, the state of charge
clamping at 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sitl.power.battery import LipoPack, LipoParams


class HoverDrain:
    """State of charge and energy of N kinematic vehicles (see the module docstring).

    Args:
        battery: each vehicle's pack parameters (its airframe's ``power.battery``).
        capacity_mah: each vehicle's pack capacity, mAh.
        hover_power_w: each vehicle's rotor power in hover, W.
        loads_w: each vehicle's payload and avionics power, W (drawn whether airborne or not).
    """

    def __init__(
        self,
        battery: Sequence[LipoParams],
        capacity_mah: Sequence[float],
        hover_power_w: Sequence[float],
        loads_w: Sequence[float],
    ) -> None:
        n = len(battery)
        self.hover_power_w = np.asarray(hover_power_w, dtype=float)
        """Rotor power in hover, W, (N,)."""
        self.loads_w = np.asarray(loads_w, dtype=float)
        """Payload and avionics power, W, (N,)."""
        if not len(capacity_mah) == len(self.hover_power_w) == len(self.loads_w) == n:
            raise ValueError("battery, capacity_mah, hover_power_w and loads_w need N entries each")
        caps = np.asarray(capacity_mah, dtype=float)
        rows: dict[LipoParams, list[int]] = {}
        for i, params in enumerate(battery):
            rows.setdefault(params, []).append(i)
        self._packs: list[tuple[slice | np.ndarray, LipoPack]] = [
            (
                slice(None) if len(rows) == 1 else np.array(idx),
                LipoPack(params, len(idx), capacity_mah=caps[idx]),
            )
            for params, idx in rows.items()
        ]
        self.soc = np.ones(n)
        """State of charge, 0..1, (N,)."""
        self.energy_j = np.zeros(n)
        """Electrical energy drawn, J, (N,)."""
        self.cutoff_at_s = np.full(n, np.nan)
        """When the loaded voltage first fell under the pack's cutoff, s; NaN: never, (N,)."""

    @property
    def remaining_pct(self) -> np.ndarray:
        """Charge remaining, % of each pack's capacity, (N,)."""
        return 100.0 * self.soc

    def draw(self, airborne: np.ndarray, dt_s: float, end_s: float) -> None:
        """Draw hover power (where ``airborne``) plus the loads for the ``dt_s`` up to ``end_s``."""
        power = np.where(airborne, self.hover_power_w + self.loads_w, self.loads_w)
        self.energy_j += power * dt_s
        for rows, pack in self._packs:
            pack.draw(power[rows], dt_s)
            if pack.cut_off.any():
                cut = self.cutoff_at_s[rows]
                self.cutoff_at_s[rows] = np.where(pack.cut_off & np.isnan(cut), end_s, cut)
                pack.cut_off[:] = False  # no motors to stop: keep draining, to 0 %
            self.soc[rows] = pack.soc
