"""What an airframe's models imply in hover and level flight: power, endurance, speed, margins.

Pure functions of one airframe's data (its YAML and URDF) and the models that fly it, so that a
table of these numbers (``benchmarks/airframe_budget.py``, docs/airframes.md) is computed, never
typed in:

- hover: every rotor carries ``m g / n`` (``k_f w_h^2 = m g / n``); the electrical power is the
  power model's (:mod:`sitl.power.propulsion`) at that thrust plus the avionics loads;
- endurance: the airframe's LiPo model (:class:`sitl.power.battery.LipoPack`) drained at that
  power from full, to a reserve of charge (PX4's BAT_LOW_THR, passed in: ``sitl`` does not read
  the autopilot's parameters) and to the low-voltage cutoff;
- top speed: the drag model's steady level flight at a given tilt
  (:func:`sitl.physics.drag.level_flight_speed_m_s`);
- thrust/weight: all rotors at ``max_speed_rad_s`` (a full pack under load) over the weight;
- yaw moment: the motor model's ``moment_coefficient_m`` beside the ratio the power model implies,
  shaft torque over thrust at hover, ``(eta P_e / w_h) / T_h``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sitl.physics.drag import AIR_DENSITY_KG_M3
from sitl.physics.earth import GRAVITY_M_S2
from sitl.power.battery import endurance_s, endurance_to_reserve_s
from sitl.power.loads import PayloadLoads
from sitl.power.propulsion import load_power_spec
from sitl.vehicles.multirotor import MultirotorSpec

TOP_SPEED_TILT_DEG = 35.0
"""Tilt at which the Typhoons' rotor drag was identified against Yuneec's 70 km/h (their YAMLs),
below PX4's MPC_TILTMAX_AIR of 45 deg; the top speed of the table is the level flight there."""


@dataclass(frozen=True)
class BudgetConditions:
    """Where and how the budget is taken."""

    reserve_soc: float
    """Charge left when the aircraft must land (PX4's BAT_LOW_THR), fraction of capacity."""
    air_density_kg_m3: float = AIR_DENSITY_KG_M3
    """Air density, kg/m^3 (default ISA sea level, the drag identification's)."""
    loads_w: float = PayloadLoads().total_w
    """Electrical loads besides the rotors, W (default: the avionics preset)."""
    top_speed_tilt_deg: float = TOP_SPEED_TILT_DEG
    """Tilt of the level flight whose speed is the top speed, deg."""


@dataclass(frozen=True)
class AirframeBudget:
    """One airframe's budget under :class:`BudgetConditions` (SI units, as named)."""

    name: str
    """Airframe name."""
    mass_kg: float
    """Total mass (the URDF's), kg."""
    hover_speed_rad_s: float
    """Rotor speed at which all rotors together carry the weight, rad/s."""
    hover_command: float
    """Hover rotor speed / max_speed_rad_s."""
    hover_power_w: float
    """Electrical power in hover, rotors + loads, W."""
    pack_energy_wh: float
    """Open-circuit energy of the pack model from full to empty, Wh."""
    endurance_to_reserve_s: float
    """Hover from a full pack until ``reserve_soc`` of its charge is left, s."""
    endurance_to_cutoff_s: float
    """Hover from a full pack until the low-voltage cutoff trips, s."""
    top_speed_m_s: float
    """Steady level-flight speed at ``top_speed_tilt_deg``, m/s."""
    thrust_to_weight: float
    """Thrust of all rotors at max_speed_rad_s over the weight."""
    moment_coefficient_m: float
    """Yaw moment / thrust of one rotor in the motor model (``moment_coefficient_m``), m."""
    shaft_torque_per_thrust_m: float
    """Shaft torque / thrust at hover implied by the power model, m."""
    propulsive_efficiency: float
    """Figure of merit x motor and ESC efficiency of the power model."""


def airframe_budget(spec: MultirotorSpec, conditions: BudgetConditions) -> AirframeBudget:
    """The budget of one airframe (see the module docstring for each quantity)."""
    power = load_power_spec(spec.yaml_path)
    prop = power.propulsion
    n = len(spec.rotors)
    weight_n = spec.mass_kg * GRAVITY_M_S2
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    w_h = float(np.sqrt(weight_n / (n * k_f)))
    thrust_n = weight_n / n
    rotors_w = float(prop.hover_power_w(np.full(n, thrust_n), conditions.air_density_kg_m3))
    hover_w = rotors_w + conditions.loads_w
    shaft_w = rotors_w / n * prop.motor_esc_efficiency
    soc = np.linspace(0.0, 1.0, 20001)
    pack_j = float(np.trapezoid(power.battery.ocv_v(soc), soc)) * power.battery.capacity_c
    level = spec.level_flight(np.radians(conditions.top_speed_tilt_deg))
    return AirframeBudget(
        name=spec.name,
        mass_kg=spec.mass_kg,
        hover_speed_rad_s=w_h,
        hover_command=w_h / spec.motor.max_speed_rad_s,
        hover_power_w=hover_w,
        pack_energy_wh=pack_j / 3600.0,
        endurance_to_reserve_s=endurance_to_reserve_s(
            power.battery, hover_w, conditions.reserve_soc, dt_s=0.1
        ),
        endurance_to_cutoff_s=endurance_s(power.battery, hover_w, dt_s=0.1),
        top_speed_m_s=level.speed_m_s,
        thrust_to_weight=n * k_f * spec.motor.max_speed_rad_s**2 / weight_n,
        moment_coefficient_m=spec.motor.moment_coefficient_m,
        shaft_torque_per_thrust_m=shaft_w / w_h / thrust_n,
        propulsive_efficiency=prop.figure_of_merit * prop.motor_esc_efficiency,
    )
