"""Hover power and endurance of the Typhoon H480 in a lockstep flight of the full stack.

Published (Yuneec, Typhoon H specifications): flight time up to 25 min on the 4S 5400 mAh
14.8 V pack, take-off weight 1695 g (with battery and CGO3+ camera). The Gazebo model flies
2.665 kg (the SDF's links summed), 57 % heavier; momentum-theory hover power grows as mass^1.5,
so with plausible propeller and motor efficiencies (FM 0.6, motor + ESC 0.76) the simulated
vehicle hovers at ~390 W for ~12.2 min, while the same power model at Yuneec's weight gives
~24.3 min (within 15 % of 25 min; 25 min exactly at 1.66 kg). Reaching 25 min at 2.665 kg would
need FM x eta = 0.93 instead of 0.46, which no propeller and motor achieve: the gap is the mass of
the SDF, not the power model. The tests below check what the physics gives; the published figure
is checked at the published weight.
"""

from __future__ import annotations

import numpy as np
import pytest

from harness.sim.simulation import Simulation, SimulationConfig
from sitl.physics.earth import GRAVITY_M_S2
from sitl.power.battery import endurance_s

PUBLISHED_FLIGHT_TIME_MIN = 25.0
"""Yuneec Typhoon H: "flight time up to 25 min"."""
PUBLISHED_TAKEOFF_MASS_KG = 1.695
"""Yuneec Typhoon H: weight 1695 g with battery and camera (the commonly quoted spec-sheet
figures; Yuneec's own page was not reachable from the machine this was written on)."""


def _hover(
    sim: Simulation, settle_s: float, window_s: float, alt_m: float = 2.5
) -> tuple[float, float]:
    """Take off, settle, then the mean electrical power (W) over ``window_s`` and its start time."""
    sim.fleet.params[0].set("MIS_TAKEOFF_ALT", alt_m)
    sim.run_lockstep(3.0)
    v = sim.fleet.vehicle(0)
    assert v.arm(False) == 0
    assert v.takeoff(None) == 0
    sim.run_lockstep(settle_s)
    start = sim.time_s
    samples = []
    for _ in range(round(window_s * 10)):
        sim.run_lockstep(0.1)
        samples.append(sim.world.truth.electrical_power_w[0])
    assert abs(sim.world.truth.velocity_enu_m_s[0, 2]) < 0.3  # hovering
    return float(np.mean(samples)), start


def _closed_form_power_w(sim: Simulation, mass_kg: float) -> float:
    power = sim.world.power
    thrust = mass_kg * GRAVITY_M_S2 / 6
    hover = power.spec.propulsion.hover_power_w([thrust] * 6, power.air_density_kg_m3)
    return float(hover + power.loads_w[0])


@pytest.fixture(scope="module")
def hover_flight():
    cfg = SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=11)
    with Simulation(cfg) as sim:
        measured_w, _ = _hover(sim, settle_s=15.0, window_s=20.0)
        yield sim, measured_w


def test_hover_power_is_the_momentum_theory_power_of_the_weight(hover_flight):
    """Measured electrical hover power = 6 rotors carrying m g / 6 each (+ avionics), within 3 %."""
    sim, measured_w = hover_flight
    expected = _closed_form_power_w(sim, sim.world.airframe.mass_kg)
    assert measured_w == pytest.approx(expected, rel=0.03)


def test_endurance_from_the_measured_hover_power(hover_flight):
    """The pack integrated at the measured hover power lasts as long as the model predicts.

    This is ~12 min against Yuneec's 25 min: see the module docstring for the gap (mass).
    """
    sim, measured_w = hover_flight
    pack = sim.world.power.spec.battery
    measured_min = endurance_s(pack, measured_w) / 60.0
    predicted_min = endurance_s(pack, _closed_form_power_w(sim, sim.world.airframe.mass_kg)) / 60
    assert measured_min == pytest.approx(predicted_min, rel=0.05)
    print(f"hover {measured_w:.1f} W -> endurance {measured_min:.2f} min (published 25 min)")


def test_the_power_model_at_yuneecs_weight_gives_the_published_flight_time(hover_flight):
    """Same propeller, motor and pack models at the published 1695 g: within 15 % of 25 min."""
    sim, _ = hover_flight
    pack = sim.world.power.spec.battery
    minutes = endurance_s(pack, _closed_form_power_w(sim, PUBLISHED_TAKEOFF_MASS_KG)) / 60.0
    assert minutes == pytest.approx(PUBLISHED_FLIGHT_TIME_MIN, rel=0.15)


@pytest.mark.slow
def test_hover_until_the_battery_is_empty():
    """Hovering on one pack: the low-voltage cutoff trips when the LiPo model says, and it falls.

    The endurance is integrated from the state of charge at the start of the hover window at the
    power measured there; the real flight's power varies a little, so 3 %.
    """
    cfg = SimulationConfig(n_vehicles=1, mavlink=False, record_hz=0, seed=12)
    with Simulation(cfg) as sim:
        measured_w, start_s = _hover(sim, settle_s=15.0, window_s=10.0, alt_m=20.0)
        soc_start = float(sim.world.power.pack.soc[0])  # at start_s + 10 s
        pack = sim.world.power.spec.battery
        predicted_s = start_s + 10.0 + endurance_s(pack, measured_w, soc=soc_start)
        sim.run_lockstep(3600.0, until=lambda s: bool(s.world.power.pack.cut_off[0]))
        assert sim.world.power.pack.cut_off[0]
        assert sim.time_s == pytest.approx(predicted_s, rel=0.03)
        sim.run_lockstep(1.0)
        assert sim.world.truth.velocity_enu_m_s[0, 2] < -5.0  # motors off: falling
        print(f"cutoff at {sim.time_s:.0f} s, predicted {predicted_s:.0f} s")
