"""Battery state as the autopilot estimates it (PX4 SITL simulates its battery inside the stack).

Current is estimated from the collective thrust command: hover current I_hover scaled by
(thrust / hover_thrust)^1.5 (rotor power grows as thrust^1.5 by momentum theory), plus avionics.
I_hover defaults to 12.5 A, what a Typhoon H480 draws to empty its 5400 mAh 4S pack in its rated
~25 min of hover. Voltage follows a linear open-circuit curve (3.5-4.2 V per cell) minus an
internal-resistance drop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BatteryModel:
    """Parameters of the estimated battery."""

    cells: int = 4
    capacity_mah: float = 5400.0
    hover_current_a: float = 12.5
    avionics_current_a: float = 0.4
    internal_resistance_ohm: float = 0.08
    empty_cell_v: float = 3.5
    full_cell_v: float = 4.2


class FleetBattery:
    """Coulomb counting for N vehicles."""

    def __init__(self, n: int, model: BatteryModel | None = None) -> None:
        self.model = model or BatteryModel()
        self.consumed_mah = np.zeros(n)
        self.current_a = np.zeros(n)
        self.capacity_mah = np.full(n, self.model.capacity_mah)

    def set_capacity(self, capacity_mah: list[float]) -> None:
        """Pack capacities (BAT1_CAPACITY); zero or negative means "unknown": the model's."""
        c = np.asarray(capacity_mah, dtype=float)
        self.capacity_mah = np.where(c > 0, c, self.model.capacity_mah)

    def update(
        self, thrust: np.ndarray, hover_thrust: np.ndarray, armed: np.ndarray, dt_s: float
    ) -> None:
        """Integrate the current drawn over dt."""
        m = self.model
        ratio = np.clip(thrust / np.maximum(hover_thrust, 1e-3), 0.0, 5.0)
        motor = np.where(armed, m.hover_current_a * ratio**1.5, 0.0)
        self.current_a = m.avionics_current_a + motor
        self.consumed_mah += self.current_a * dt_s / 3.6

    @property
    def remaining(self) -> np.ndarray:
        """State of charge, 0..1."""
        return np.minimum(np.maximum(1.0 - self.consumed_mah / self.capacity_mah, 0.0), 1.0)

    @property
    def voltage_v(self) -> np.ndarray:
        """Terminal voltage under the present load, V."""
        m = self.model
        ocv = m.cells * (m.empty_cell_v + (m.full_cell_v - m.empty_cell_v) * self.remaining)
        return ocv - self.current_a * m.internal_resistance_ohm
