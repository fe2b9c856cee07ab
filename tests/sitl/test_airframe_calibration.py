"""typhoon_h480_yuneec against the published aircraft and first principles.

Oracles, none of them the airframe's own constants:

- Yuneec Typhoon H specifications: take-off weight 1695 g, flight time up to 25 min, maximum
  speed 70 km/h (docs/airframes.md: the flight time is taken as hover from a full pack to PX4's
  low-battery reserve, BAT_LOW_THR);
- a thrust/weight of 2 (the design margin the airframe assumes), measured as the acceleration
  the simulated body gets at full command;
- momentum theory (Leishman, Principles of Helicopter Aerodynamics, 2006, eq. 2.15): a rotor of
  disc area A giving thrust T needs the shaft power T^1.5 / (FM sqrt(2 rho A)), so its shaft
  torque per thrust is that over w T; written out here from the published mass, the 9 in
  propeller, ISA air and the figure of merit.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sitl_test_helpers import actuator_message, hover_trim, make_world, run
from test_px4_model_mass_properties import TYPHOON_SDF_LINKS, lump

from autopilot_emu.params import ParamStore
from sitl.physics.rotors import Spin
from sitl.power.battery import LipoPack
from sitl.power.propulsion import load_power_spec
from sitl.vehicles.budget import BudgetConditions, airframe_budget
from sitl.vehicles.multirotor import load_airframe

NAME = "typhoon_h480_yuneec"
PUBLISHED_MASS_KG = 1.695
"""Yuneec Typhoon H: take-off weight 1695 g with battery and CGO3+ camera."""
PUBLISHED_FLIGHT_TIME_S = 25.0 * 60.0
"""Yuneec Typhoon H: "flight time up to 25 min"."""
PUBLISHED_TOP_SPEED_M_S = 70.0 / 3.6
"""Yuneec Typhoon H: maximum flight speed 70 km/h."""
PROPELLER_DIAMETER_M = 9 * 0.0254
"""The Typhoon H's 9 x 6 in propellers."""
G_M_S2 = 9.81
SEA_LEVEL_AIR_KG_M3 = 1.225
"""ISA sea level (ICAO Doc 7488)."""


def test_hover_drains_the_pack_to_the_low_battery_reserve_in_the_published_time():
    """Hover power measured on the simulated body (sea level, hover trim), drawn from a full pack
    of the battery model until PX4's BAT_LOW_THR is left: 25 min. Achieved -0.27 %."""
    reserve = float(ParamStore().get("BAT_LOW_THR"))
    assert reserve == pytest.approx(0.15)  # PX4's default
    with make_world(airframe=NAME, origin_alt_amsl_m=0.0, spawn_altitude_m=20.0) as world:
        command = [actuator_message(list(hover_trim(world.airframe)))]
        run(world, 0.3, command)  # the rotors spin up from rest, then carry the weight
        v0 = world.truth.velocity_enu_m_s[0, 2]
        run(world, 0.2, command)
        assert abs(world.truth.velocity_enu_m_s[0, 2] - v0) < 1e-3  # no vertical acceleration
        power_w = float(world.truth.electrical_power_w[0])
        pack = LipoPack(world.power.spec.battery, 1)
    dt_s, t_s = 0.5, 0.0
    while pack.soc[0] > reserve:
        pack.draw(np.array([power_w]), dt_s)
        t_s += dt_s
    assert not pack.cut_off[0]
    assert t_s == pytest.approx(PUBLISHED_FLIGHT_TIME_S, rel=0.004)


def test_top_speed_is_the_published_one_below_the_tilt_limit():
    """The drag model's steady level flight at 35 deg of tilt is 70 km/h; PX4 allows 45 deg."""
    tilt_max_deg = float(ParamStore().get("MPC_TILTMAX_AIR"))
    flight = load_airframe(NAME).level_flight(math.radians(35.0))
    assert tilt_max_deg > 35.0
    assert flight.speed_m_s == pytest.approx(PUBLISHED_TOP_SPEED_M_S, rel=2e-4)  # achieved 1.3e-4


def test_full_command_lifts_twice_the_weight():
    """All rotors at full command on a fresh pack (16.2 V): the body accelerates up at about 1 g.

    Measured from the simulated body's vertical velocity over 20 ms once the rotors have spun up,
    not from the airframe's constants: 1.9956 (the rotor limit 805 rad/s gives 1.9989; the
    fuselage drag at 0.6 m/s and the last 0.03 % of the spin-up take the rest).
    """
    with make_world(airframe=NAME, spawn_altitude_m=50.0) as world:
        command = [actuator_message([1.0] * 6)]
        run(world, 0.09, command)  # rotors from rest to full: 7 time constants
        v0 = world.truth.velocity_enu_m_s[0, 2]
        run(world, 0.02, command)
        v1 = world.truth.velocity_enu_m_s[0, 2]
    assert 0.0 < v0 < v1 < 1.0
    thrust_to_weight = 1.0 + (v1 - v0) / 0.02 / G_M_S2
    assert thrust_to_weight == pytest.approx(2.0, abs=6.5e-3)


def test_yaw_moment_is_the_shaft_torque_momentum_theory_implies():
    """k_m of the motor model = Q / T at hover, Q = T^1.5 / (FM sqrt(2 rho A)) / w (first
    principles, sea level). Achieved 0.1 % (the YAML rounds to 0.0142)."""
    spec = load_airframe(NAME)
    fm = load_power_spec(spec.yaml_path).propulsion.figure_of_merit
    thrust_n = PUBLISHED_MASS_KG * G_M_S2 / 6
    area_m2 = math.pi * PROPELLER_DIAMETER_M**2 / 4
    shaft_w = thrust_n**1.5 / (fm * math.sqrt(2 * SEA_LEVEL_AIR_KG_M3 * area_m2))
    w_rad_s = math.sqrt(thrust_n / spec.motor.thrust_coefficient_n_s2_rad2)
    assert spec.motor.moment_coefficient_m == pytest.approx(
        shaft_w / w_rad_s / thrust_n, rel=1.5e-3
    )


def test_yaw_step_accelerates_as_the_shaft_torque_over_the_inertia():
    """Counter-clockwise rotors faster: the body yaws right at (sum of the rotors' shaft torques)
    / I_zz, with the shaft torque of momentum theory (previous test) and I_zz the SDF's lumped
    inertia scaled to 1695 g (test_px4_model_mass_properties), both computed here. Achieved
    0.11 %: the YAML's k_m 0.0142 against 0.014185."""
    _, _, inertia = lump(TYPHOON_SDF_LINKS, PUBLISHED_MASS_KG / 2.665)
    spec = load_airframe(NAME)
    fm = load_power_spec(spec.yaml_path).propulsion.figure_of_merit
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    area_m2 = math.pi * PROPELLER_DIAMETER_M**2 / 4
    # Q / T = sqrt(k_f) / (FM sqrt(2 rho A)) at any speed (Q ~ w^2 like T).
    torque_per_thrust_m = math.sqrt(k_f) / (fm * math.sqrt(2 * SEA_LEVEL_AIR_KG_M3 * area_m2))
    ccw = np.array([1.0 if r.spin is Spin.CCW else -1.0 for r in spec.rotors])
    with make_world(airframe=NAME, spawn_altitude_m=20.0) as world:
        u = hover_trim(spec)
        run(world, 0.3, [actuator_message(list(u))])
        rate0 = world.truth.angular_velocity_body_frd_rad_s[0, 2]
        step = [actuator_message(list(u + 0.05 * (ccw > 0)))]
        predicted = rate0
        for _ in range(100):  # 0.2 s
            w = world.truth.rotor_speed_rad_s[0]
            torque = float(ccw @ (torque_per_thrust_m * k_f * w**2))
            predicted += torque / inertia[2, 2] / world.config.physics_hz
            world.step(step)
        rate = world.truth.angular_velocity_body_frd_rad_s[0, 2]
    assert predicted > 0.1
    assert rate == pytest.approx(predicted, rel=1.6e-3)


def test_the_budget_table_gives_the_published_aircraft():
    """sitl.vehicles.budget (the table of docs/airframes.md) at ISA sea level: the published
    flight time (achieved -0.24 %), top speed (1.3e-4), thrust/weight 2 (-0.0011), and a k_m
    equal to its own shaft torque / thrust (0.11 %)."""
    reserve = float(ParamStore().get("BAT_LOW_THR"))
    budget = airframe_budget(load_airframe(NAME), BudgetConditions(reserve_soc=reserve))
    assert budget.mass_kg == PUBLISHED_MASS_KG
    assert budget.endurance_to_reserve_s == pytest.approx(PUBLISHED_FLIGHT_TIME_S, rel=0.0036)
    assert budget.endurance_to_cutoff_s > budget.endurance_to_reserve_s
    assert budget.top_speed_m_s == pytest.approx(PUBLISHED_TOP_SPEED_M_S, rel=2e-4)
    assert budget.thrust_to_weight == pytest.approx(2.0, abs=1.7e-3)
    assert budget.moment_coefficient_m == pytest.approx(
        budget.shaft_torque_per_thrust_m, rel=1.6e-3
    )
