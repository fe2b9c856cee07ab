"""The power system of a fleet: rotor power + loads drawn from each vehicle's pack.

Advanced by the World at ``update_hz`` (not every physics step): the electrical power of the
rotors (from their true speeds, :mod:`sitl.power.propulsion`) plus each vehicle's payload loads
is drawn from its LiPo pack for one period, and the new terminal voltage sets the rotor speed
limit ``w_max = max_speed_rad_s * V / max_speed_voltage_v`` (zero once the ESCs' low-voltage
cutoff has tripped) until the next update.

With ``bench_supply`` the vehicles run from an ideal constant-voltage supply at the airframe's
``max_speed_voltage_v`` instead: rotor speed = command x max_speed_rad_s exactly (as Gazebo) and
nothing drains; the power is still computed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sitl.power.battery import LipoPack
from sitl.power.loads import PayloadLoads
from sitl.power.propulsion import PowerSpec


class FleetPower:
    """Electrical state of N vehicles of one airframe."""

    def __init__(
        self,
        spec: PowerSpec,
        thrust_coefficient_n_s2_rad2: float,
        air_density_kg_m3: float,
        loads: Sequence[PayloadLoads],
        bench_supply: bool = False,
    ) -> None:
        n = len(loads)
        self.spec = spec
        self.bench_supply = bench_supply
        self.air_density_kg_m3 = air_density_kg_m3
        self._k_power = spec.propulsion.power_coefficient_w_s3_rad3(
            thrust_coefficient_n_s2_rad2, air_density_kg_m3
        )
        self.loads_w = np.array([ld.total_w for ld in loads], dtype=float)
        """Payload and avionics power per vehicle, W, (N,)."""
        self.pack = LipoPack(spec.battery, n)
        self.rotor_power_w = np.zeros(n)
        """Electrical power of the rotors of each vehicle, W, (N,)."""
        self.speed_scale = np.ones(n)
        """Rotor speed at full command / the motor model's max speed, (N,)."""
        self._update_scale()

    @property
    def electrical_power_w(self) -> np.ndarray:
        """Total electrical power of each vehicle (rotors + loads), W, (N,)."""
        return self.rotor_power_w + self.loads_w

    @property
    def voltage_v(self) -> np.ndarray:
        """Supply voltage at the terminals, V, (N,)."""
        if self.bench_supply:
            return np.full_like(self.loads_w, self.spec.propulsion.max_speed_voltage_v)
        return self.pack.voltage_v

    @property
    def current_a(self) -> np.ndarray:
        """Current drawn from the supply, A, (N,)."""
        if self.bench_supply:
            return self.electrical_power_w / self.spec.propulsion.max_speed_voltage_v
        return self.pack.current_a

    def rotor_power_of(self, rotor_speed_rad_s: np.ndarray) -> np.ndarray:
        """Electrical power of the rotors at these speeds (N, n_rotors), summed per vehicle, W."""
        w = np.abs(rotor_speed_rad_s)
        return self._k_power * np.einsum("ij,ij,ij->i", w, w, w)

    def update(self, rotor_speed_rad_s: np.ndarray, dt_s: float) -> None:
        """Draw the present power for ``dt_s`` and refresh the rotor speed limit."""
        self.rotor_power_w = self.rotor_power_of(rotor_speed_rad_s)
        if not self.bench_supply:
            self.pack.draw(self.electrical_power_w, dt_s)
            self._update_scale()

    def _update_scale(self) -> None:
        if self.bench_supply:
            return
        scale = self.pack.voltage_v / self.spec.propulsion.max_speed_voltage_v
        self.speed_scale = np.where(self.pack.cut_off, 0.0, np.maximum(scale, 0.0))
