"""The power system of a fleet: rotor power + loads drawn from each vehicle's pack.

Advanced by the World at ``battery_hz`` (not every physics step): the electrical power of the
rotors (from their true speeds, :mod:`sitl.power.propulsion`) plus each vehicle's payload loads
is drawn from its LiPo pack for one period; the resulting terminal voltage V sets the rotor speed
limit ``w_max = max_speed_rad_s * V / max_speed_voltage_v`` until the next update (zero once the
ESCs' low-voltage cutoff has tripped).

This explicit feedback (power -> sag -> speed limit -> power) converges when its loop gain
``dV'/dV = -2 R a V`` is below 1 in magnitude, with ``P = a V^3`` the rotor power at full command;
the constructor checks it at the worst case (full pack, every rotor at full command) and refuses a
pack too weak for the motors (the case where full throttle would pass the pack's maximum power).

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
        max_speed_rad_s: float,
        n_rotors: int,
        air_density_kg_m3: float,
        loads: Sequence[PayloadLoads],
        bench_supply: bool = False,
        soc: float = 1.0,
        capacity_mah: Sequence[float] | None = None,
    ) -> None:
        n = len(loads)
        self.spec = spec
        self.bench_supply = bench_supply
        self.air_density_kg_m3 = air_density_kg_m3
        self._k_power = spec.propulsion.power_coefficient_w_s3_rad3(
            thrust_coefficient_n_s2_rad2, air_density_kg_m3
        )
        self.loop_gain = self._loop_gain(max_speed_rad_s, n_rotors)
        """Worst-case gain of the voltage feedback (must be < 1)."""
        if not bench_supply and self.loop_gain >= 1.0:
            raise ValueError(
                f"battery too weak for the motors: full throttle on a full pack gives a voltage "
                f"feedback gain {self.loop_gain:.2f} >= 1 (beyond the pack's maximum power); "
                "lower cell_internal_resistance_ohm or add cells"
            )
        self.loads_w = np.array([ld.total_w for ld in loads], dtype=float)
        """Payload and avionics power per vehicle, W, (N,)."""
        self.pack = LipoPack(spec.battery, n, soc, capacity_mah)
        """The packs (``capacity_mah``: one per vehicle; None: the spec's battery's)."""
        self.rotor_power_w = np.zeros(n)
        """Electrical power of the rotors of each vehicle, W, (N,)."""
        self.speed_scale = np.ones(n)
        """Rotor speed at full command / the motor model's max speed, (N,)."""
        if not bench_supply:
            self.speed_scale = self.pack.voltage_v / spec.propulsion.max_speed_voltage_v

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
        if self.bench_supply:
            return
        pack = self.pack
        pack.draw(self.rotor_power_w + self.loads_w, dt_s)
        scale = pack.voltage_v * (1.0 / self.spec.propulsion.max_speed_voltage_v)
        self.speed_scale = np.where(pack.cut_off, 0.0, scale) if pack.cut_off.any() else scale

    def _loop_gain(self, max_speed_rad_s: float, n_rotors: int) -> float:
        """``2 R a V_oc`` at full charge with every rotor at full command."""
        battery = self.spec.battery
        v_oc = float(battery.ocv_v(1.0))
        a = (
            self._k_power
            * n_rotors
            * (max_speed_rad_s / self.spec.propulsion.max_speed_voltage_v) ** 3
        )
        return 2.0 * battery.resistance_ohm * a * v_oc
