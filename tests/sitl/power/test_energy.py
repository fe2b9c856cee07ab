"""Energy ledger: per node, per component, per task (seed 000, Table I powers)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from sitl.physics.earth import GRAVITY_M_S2
from sitl.power.energy import EnergyLedger, NodePowerProfile, TaskInterval
from sitl.world import World, WorldConfig


def test_fog_node_hand_computed():
    """Fog, 10 s, 0.5 s LTE + 2 s WiFi airtime, no samples: 27*10 + 100*0.5 + 1*2 + 120*10 J."""
    ledger = EnergyLedger()
    ledger.add_node("fog1", "fog")
    ledger.set_airtime("fog1", {"lte": 0.5, "wifi": 2.0, "uart": 9.0})
    node = ledger.report(5.0, 15.0)["nodes"]["fog1"]
    assert node["components_j"] == pytest.approx(
        {
            "embedded_computer": 270.0,
            "radio": 2.0,
            "mobile_comm": 50.0,
            "cloud": 0.0,
            "propulsion": 1200.0,
        }
    )
    assert node["total_j"] == pytest.approx(270.0 + 50.0 + 2.0 + 1200.0)
    assert node["mean_power_w"] == pytest.approx(152.2)
    assert node["mean_power_by_component_w"]["mobile_comm"] == pytest.approx(5.0)
    assert node["propulsion_source"] == "fallback"
    assert node["propulsion_time_s"] == pytest.approx(10.0)


def test_roles_carry_their_components():
    """Edge: computer + radio + rotors; cloud: 65 W only; ground: computer + SiK radio."""
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    ledger.add_node("c", "cloud")
    ledger.add_node("g", "ground")
    ledger.set_airtimes({"e": {"wifi": 1.5, "lte": 0.5}, "c": {"wired": 3.0}, "g": {"sik": 4.0}})
    report = ledger.report(0.0, 20.0)
    nodes = report["nodes"]
    # An edge's 4G module (seed 000 Table II) costs 100 W only while it transmits.
    assert nodes["e"]["total_j"] == pytest.approx(27 * 20 + 1 * 1.5 + 100 * 0.5 + 120 * 20)
    assert nodes["c"]["total_j"] == pytest.approx(65 * 20)
    assert nodes["c"]["propulsion_source"] == "none"
    assert nodes["g"]["total_j"] == pytest.approx(27 * 20 + 1 * 4.0)
    assert report["components_j"]["radio"] == pytest.approx(5.5)
    assert report["total_j"] == pytest.approx(sum(n["total_j"] for n in nodes.values()))


def test_idle_radio_draw_counts_the_time_not_transmitting():
    """E_k = P_tx a_k + P_idle (T - a_k), per radio; a fog's idle LTE module counts too."""
    profile = NodePowerProfile(radio_idle_w=0.1, mobile_comm_idle_w=2.0)
    ledger = EnergyLedger()
    ledger.add_node("f", "fog", profile)
    ledger.set_airtime("f", {"wifi": 2.0})
    components = ledger.report(0.0, 10.0)["nodes"]["f"]["components_j"]
    assert components["radio"] == pytest.approx(1.0 * 2.0 + 0.1 * 8.0)
    assert components["mobile_comm"] == pytest.approx(2.0 * 10.0)


def test_trapezoid_is_exact_for_a_ramp_including_window_ends_between_samples():
    """P = 100 + 20 t sampled every 0.1 s; over [0.05, 3.33]: 100 d + 10 (t1^2 - t0^2)."""
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    for t in np.arange(0.0, 5.0001, 0.1):
        ledger.record_propulsion("e", float(t), 100.0 + 20.0 * float(t))
    t0, t1 = 0.05, 3.33
    node = ledger.report(t0, t1)["nodes"]["e"]
    exact = 100.0 * (t1 - t0) + 10.0 * (t1**2 - t0**2)
    assert node["components_j"]["propulsion"] == pytest.approx(exact, rel=1e-12)
    assert node["propulsion_source"] == "flight_model"


def test_trapezoid_error_on_a_parabola_is_the_textbook_one():
    """P = 50 t^2, h = 0.01 s over [0, 2]: trapezoid = exact + h^2 (b - a) P'' / 12."""
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    h = 0.01
    for t in np.linspace(0.0, 2.0, 201):
        ledger.record_propulsion("e", float(t), 50.0 * float(t) ** 2)
    propulsion = ledger.report(0.0, 2.0)["nodes"]["e"]["components_j"]["propulsion"]
    exact = 50.0 * 2.0**3 / 3.0
    assert propulsion - exact == pytest.approx(h**2 * 2.0 * 100.0 / 12.0, rel=1e-6)


def test_propulsion_counts_only_the_sampled_span():
    """Samples over [2, 6] s at 200 W, report [0, 10]: 800 J, 4 s covered (no extrapolation)."""
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    for t in (2.0, 4.0, 6.0):
        ledger.record_propulsion("e", t, 200.0)
    node = ledger.report(0.0, 10.0)["nodes"]["e"]
    assert node["components_j"]["propulsion"] == pytest.approx(800.0)
    assert node["propulsion_time_s"] == pytest.approx(4.0)


def test_fallback_120_w_while_flying_only():
    """No samples: 120 W over the flight windows' union ([2, 5] u [4, 7] = 5 s) -> 600 J."""
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    ledger.add_flight_window("e", 2.0, 5.0)
    ledger.add_flight_window("e", 4.0, 7.0)
    report = ledger.report(0.0, 10.0, [("e", "nav", 0.0, 3.0), ("e", "nav", 3.0, 10.0)])
    node = report["nodes"]["e"]
    assert node["components_j"]["propulsion"] == pytest.approx(600.0)
    assert node["propulsion_source"] == "fallback"
    assert node["propulsion_time_s"] == pytest.approx(5.0)
    first, second = report["task_instances"]
    assert first["components_j"]["propulsion"] == pytest.approx(120.0)
    assert second["components_j"]["propulsion"] == pytest.approx(480.0)


def test_tasks_tiling_the_run_sum_to_the_node_totals():
    """Per-task energies over intervals that tile [t0, t1] add up to each node's total."""
    ledger = EnergyLedger()
    ledger.add_node("e1", "edge")
    ledger.add_node("f1", "fog")
    ledger.add_node("cloud", "cloud")
    for t in np.linspace(0.0, 30.0, 301):
        ledger.record_propulsion_fleet(
            ["e1", "f1"], float(t), np.array([300.0 + 40.0 * math.sin(t), 350.0 + 5.0 * t])
        )
    ledger.set_airtimes({"e1": {"wifi": 3.0}, "f1": {"wifi": 1.0, "lte": 2.5}})
    tasks = [
        ("e1", "nav", 0.0, 7.3),
        ("e1", "avoid", 7.3, 12.0),
        ("e1", "nav", 12.0, 30.0),
        TaskInterval("f1", "role", 0.0, 18.25),
        TaskInterval("f1", "conn", 18.25, 30.0),
        ("cloud", "planning", 0.0, 30.0),
    ]
    report = ledger.report(0.0, 30.0, tasks)
    for node_id, node in report["nodes"].items():
        parts = [i for i in report["task_instances"] if i["node_id"] == node_id]
        assert sum(i["energy_j"] for i in parts) == pytest.approx(node["total_j"], rel=1e-12)
        for component, energy in node["components_j"].items():
            split = sum(i["components_j"][component] for i in parts)
            assert split == pytest.approx(energy, rel=1e-12, abs=1e-9)
    assert report["total_j"] == pytest.approx(
        sum(t["total_j"] for t in report["tasks"].values()), rel=1e-12
    )
    nav = report["tasks"]["nav"]
    assert nav["instances"] == 2
    assert nav["duration_s"] == pytest.approx(25.3)
    assert nav["mean_j_per_task"] == pytest.approx(nav["total_j"] / 2)


def test_task_radio_energy_uses_the_mean_airtime_share():
    """A 2 s task of a fog node with 0.5 s LTE in 10 s gets 100 W x 5 % x 2 s = 10 J of LTE."""
    ledger = EnergyLedger()
    ledger.add_node("f", "fog")
    ledger.set_airtime("f", {"lte": 0.5})
    task = ledger.report(0.0, 10.0, [("f", "compress", 4.0, 6.0)])["tasks"]["compress"]
    assert task["components_j"]["mobile_comm"] == pytest.approx(10.0)
    assert task["mean_j_per_task"] == pytest.approx(27 * 2 + 10.0 + 120 * 2)


def test_report_is_json_serialisable():
    """json.dumps of a report with every role and tasks round-trips to an equal dict."""
    ledger = EnergyLedger()
    for node_id, role in (("e", "edge"), ("f", "fog"), ("c", "cloud"), ("g", "ground")):
        ledger.add_node(node_id, role)
    ledger.record_propulsion_fleet(["e", "f"], 0.0, np.array([310.0, 320.0]))
    ledger.record_propulsion_fleet(["e", "f"], 1.0, np.float32([330.0, 300.0]))
    ledger.set_airtime("f", {"lte": np.float64(0.25)})
    report = ledger.report(0, 1, [("e", "nav", 0, 1)])
    assert json.loads(json.dumps(report)) == report


def test_rotor_power_of_a_hovering_world_integrates_to_power_times_time():
    """FleetPower.rotor_power_w sampled each step at hover: E / T = momentum-theory hover power."""
    world = World(WorldConfig(spawn_altitude_m=10.0, bench_supply=True))
    ledger = EnergyLedger()
    ledger.add_node("uav0", "edge")
    controls = [world.airframe.hover_command] * 6 + [0.0] * 10
    armed = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED
    command = [mavlink2.MAVLink_hil_actuator_controls_message(0, controls, armed, 0)]
    for _ in range(round(1.3 * world.config.physics_hz)):
        world.step(command)
        if world.time_s >= 0.3:  # rotors spun up
            ledger.record_propulsion_fleet(["uav0"], world.time_s, world.power.rotor_power_w)
    prop = world.power.spec.propulsion
    rho = world.power.air_density_kg_m3
    thrust = world.airframe.mass_kg * GRAVITY_M_S2 / 6
    area = math.pi * prop.rotor_diameter_m**2 / 4
    hover_w = (
        6
        * thrust**1.5
        / (prop.figure_of_merit * prop.motor_esc_efficiency * math.sqrt(2 * rho * area))
    )
    t0 = 0.3 + 1.0 / world.config.physics_hz
    report = ledger.report(t0, world.time_s)
    world.close()
    node = report["nodes"]["uav0"]
    assert node["propulsion_source"] == "flight_model"
    assert node["mean_power_by_component_w"]["propulsion"] == pytest.approx(hover_w, rel=1e-3)


@pytest.mark.parametrize(
    ("make", "field"),
    [
        (lambda: EnergyLedger().add_node("x", "satellite"), "role"),
        (lambda: NodePowerProfile(radio_w=-1.0), "radio_w"),
        (lambda: NodePowerProfile(cloud_w=math.nan), "cloud_w"),
        (lambda: TaskInterval("x", "nav", 5.0, 4.0), "end_s"),
        (lambda: _ledger().report(10.0, 5.0), "t1_s"),
        (lambda: _ledger().report(0.0, 10.0, [("e", "nav", 3.0, 2.0)]), "end_s"),
        (lambda: _ledger().report(0.0, 10.0, [("e", "nav", 5.0, 11.0)]), "start_s..end_s"),
        (lambda: _ledger().report(0.0, 10.0, [("z", "nav", 1.0, 2.0)]), "node_id"),
        (lambda: _ledger().add_flight_window("e", 3.0, 1.0), "end_s"),
        (lambda: _ledger().record_propulsion("e", 0.0, -5.0), "power_w"),
        (lambda: _ledger().record_propulsion("c", 0.0, 5.0), "node_id"),
        (lambda: _ledger().add_node("e", "edge"), "node_id"),
        (lambda: _ledger().set_airtime("e", {"wifi": -1.0}), "airtime_s['wifi']"),
        (
            lambda: _ledger().record_propulsion_fleet(["e"], 0.0, np.zeros(2)),
            "power_w",
        ),
    ],
)
def test_bad_input_names_the_field(make, field):
    """Unknown role/kind/node, negative power, end before start, overlong airtime: ValueError."""
    with pytest.raises(ValueError, match=field.replace("[", r"\[").replace("]", r"\]")):
        make()


def test_samples_must_move_forward_in_time():
    ledger = _ledger()
    ledger.record_propulsion("e", 1.0, 100.0)
    with pytest.raises(ValueError, match="t_s"):
        ledger.record_propulsion("e", 1.0, 100.0)


def _ledger(airtime: dict[str, float] | None = None) -> EnergyLedger:
    ledger = EnergyLedger()
    ledger.add_node("e", "edge")
    ledger.add_node("c", "cloud")
    if airtime:
        ledger.set_airtime("e", airtime)
    return ledger


def test_airtime_on_a_component_the_node_lacks_costs_nothing():
    """The cloud's LTE downlink is sent by the operator's base station: 65 W only."""
    ledger = _ledger()
    ledger.set_airtime("c", {"lte": 4.0})
    report = ledger.report(0.0, 10.0)
    assert report["nodes"]["c"]["total_j"] == pytest.approx(650.0)
    assert report["nodes"]["c"]["airtime_s"] == {"lte": 4.0}


def test_a_radio_busy_longer_than_the_window_counts_as_always_on():
    """Airtime summed over peers beyond the window: the radio transmits the whole window."""
    ledger = _ledger(airtime={"wifi": 11.0})
    node = ledger.report(0.0, 10.0)["nodes"]["e"]
    assert node["components_j"]["radio"] == pytest.approx(1.0 * 10.0)


def test_a_link_kind_the_ledger_does_not_know_costs_nothing():
    """A custom preset's kind (``wifi6``) is listed with its airtime but draws no power."""
    ledger = _ledger(airtime={"wifi6": 2.0, "wifi": 1.0})
    node = ledger.report(0.0, 10.0)["nodes"]["e"]
    assert node["airtime_s"]["wifi6"] == 2.0
    assert node["components_j"]["radio"] == pytest.approx(1.0)
