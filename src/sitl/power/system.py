"""The power system of a fleet: rotor power + loads drawn from each vehicle's pack.

Advanced by the World at ``battery_hz`` (not every physics step): the electrical power of the
rotors (from their true speeds, :mod:`sitl.power.propulsion`) plus each vehicle's payload loads
is drawn from its LiPo pack for one period. The rotor speed limit until the next update is
``w_max = max_speed_rad_s * V / max_speed_voltage_v`` (zero once the ESCs' low-voltage cutoff has
tripped), with V the terminal voltage at which the pack supplies the commanded speeds: with
normalised commands u_i, ``P(V) = a V^3 + P_loads``, ``a = k_P (w_max0 / V_ref)^3 sum u_i^3``, and
``V = V_oc - R P(V) / V``, i.e. the largest root of the convex cubic

    g(V) = a R V^3 + V^2 - V_oc V + R P_loads

(Newton from V_oc, monotone). Without a root (demand beyond the pack's power) V is the minimiser
of g, the maximum-power point. Solving the equilibrium, rather than feeding the last voltage back,
keeps the loop stable whatever the pack resistance.

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
        soc: float = 1.0,
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
        self.pack = LipoPack(spec.battery, n, soc)
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

    def update(
        self,
        rotor_speed_rad_s: np.ndarray,
        commands: np.ndarray,
        max_speed_rad_s: float,
        dt_s: float,
    ) -> None:
        """Draw the present power for ``dt_s``; set the speed limit for the commands (N, n_rot)."""
        self.rotor_power_w = self.rotor_power_of(rotor_speed_rad_s)
        if self.bench_supply:
            return
        self.pack.draw(self.electrical_power_w, dt_s)
        v_ref = self.spec.propulsion.max_speed_voltage_v
        u = np.clip(commands, 0.0, 1.0)
        a = self._k_power * (max_speed_rad_s / v_ref) ** 3 * np.einsum("ij,ij,ij->i", u, u, u)
        v = self._supply_voltage(a)
        self.speed_scale = np.where(self.pack.cut_off, 0.0, v / v_ref)

    def _supply_voltage(self, a: np.ndarray) -> np.ndarray:
        """Terminal voltage at which the pack supplies ``a V^3 + loads`` (see module doc), V."""
        r = self.spec.battery.resistance_ohm
        v_oc = self.spec.battery.ocv_v(self.pack.soc)
        c = r * self.loads_w
        ar = a * r
        v_min = v_oc / (1.0 + np.sqrt(1.0 + 3.0 * ar * v_oc))  # g'(v_min) = 0
        v = v_oc.copy()
        for _ in range(8):  # convex g, started right of its largest root: monotone Newton
            g = ar * v**3 + v * v - v_oc * v + c
            v = v - g / (3.0 * ar * v * v + 2.0 * v - v_oc)
        g_min = ar * v_min**3 + v_min * v_min - v_oc * v_min + c
        return np.where(g_min >= 0.0, v_min, np.maximum(v, v_min))
