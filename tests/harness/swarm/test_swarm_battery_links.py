"""Swarm fidelity: packs drained by hover + loads, links within range, active-vehicle series."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from harness.scenarios.spec import parse_scenario
from harness.swarm.engine import SwarmEngine
from harness.swarm.run import run_swarm
from sitl.kinematic_fleet import KinematicFleet
from sitl.physics.earth import GRAVITY_M_S2
from sitl.power.loads import LOAD_PRESETS
from sitl.power.propulsion import load_power_spec
from sitl.vehicles.kinematics import load_kinematic_limits
from sitl.vehicles.multirotor import load_airframe

AIRFRAME = "typhoon_h480_yuneec"
HOVER_UNTIL_S = 20.0

PROGRAM = f"""
def swarm_program(env, vehicle, node):
    return Hop(env, vehicle)


class Hop:
    '''Take off to 10 m, hover, land at {HOVER_UNTIL_S} s; records what it was told.'''

    error = None

    def __init__(self, env, vehicle):
        self.env = env
        self.vehicle = vehicle
        self.landing = False
        self.battery_seen = []

    @property
    def done(self):
        return self.landing and not self.vehicle.airborne

    def decide(self, now_s):
        self.battery_seen.append(self.vehicle.battery_remaining_pct)
        if now_s == 0.0:
            self.vehicle.takeoff(10.0)
        elif now_s >= {HOVER_UNTIL_S} and not self.landing:
            self.vehicle.land()
            self.landing = True

    def metrics(self):
        me = self.env.fleet[self.env.vehicle - 1]
        return {{
            "fleet_capacity_mah": (me["battery_capacity_mah"], "mAh"),
            "decision_trait": (me["traits"].get("decision", -1.0), "1"),
            "battery_first": (self.battery_seen[0], "%"),
            "battery_last": (self.battery_seen[-1], "%"),
        }}
"""


@pytest.fixture
def hop_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "swarm_hop_role.py").write_text(PROGRAM)
    monkeypatch.syspath_prepend(str(tmp_path))
    return "swarm_hop_role"


def hop_scenario(module: str, **fleet: object):
    """Two vehicles 5 m apart (links within 8 m) hop together; no world, no events."""
    spec = {
        "name": "hop",
        "fidelity": "swarm",
        "swarm": {"step_hz": 10, "decision_hz": 1, "neighbours": 1, "link_range_m": 8.0},
        "duration_s": 60,
        "spacing_m": 5,
        "fleet": [{"role": "hop", "count": 2, "airframe": AIRFRAME, **fleet}],
        "roles": {"hop": {"module": module}},
    }
    return parse_scenario(yaml.safe_dump(spec))


def hover_power_w() -> float:
    """Momentum theory by hand: n T^1.5 / sqrt(2 rho A) / (FM eta), T = m g / n (Leishman 2.15)."""
    airframe = load_airframe(AIRFRAME)
    prop = load_power_spec(airframe.yaml_path).propulsion
    n = len(airframe.rotors)
    thrust = airframe.mass_kg * GRAVITY_M_S2 / n
    area = math.pi * prop.rotor_diameter_m**2 / 4.0
    ideal = n * thrust**1.5 / math.sqrt(2.0 * 1.225 * area)
    return ideal / (prop.figure_of_merit * prop.motor_esc_efficiency)


def test_two_vehicles_in_range_link_at_every_decision_both_fly(hop_module, tmp_path):
    """Links: one each per decision while both are up; the series and the fleet keys agree."""
    report = run_swarm(hop_scenario(hop_module), seed=0, run_dir=tmp_path / "run")
    assert report["passed"], report["checks"]
    fleet, v1, v2 = report["fleet"], report["vehicles"]["vehicle1"], report["vehicles"]["vehicle2"]
    airborne_s = v1["airborne_time"]["value"]
    # up from the first step after the t = 0 decision until touch-down after 20 s (10 m at
    # <= 1.5 m/s): the decisions at 1 s ... floor(airborne) s see both up, one link each
    assert HOVER_UNTIL_S + 10.0 / 1.5 <= airborne_s <= HOVER_UNTIL_S + 10.0
    expected_links = math.floor(airborne_s)
    assert v1["links_total"]["value"] == v2["links_total"]["value"] == expected_links
    assert fleet["links_per_agent_mean"]["value"] == expected_links
    assert fleet["links_per_step_mean"]["value"] == 1.0
    assert fleet["active_max"]["value"] == 2
    assert fleet["mission_time"]["value"] == pytest.approx(airborne_s, abs=1e-9)
    series = report["series"]
    assert len(series["time_s"]) == len(series["active"]) == len(series["links_mean"])
    assert series["time_s"][:3] == [0.0, 1.0, 2.0]
    assert series["active"][0] == 0 and sum(a == 2 for a in series["active"]) == expected_links
    tracks = np.load(tmp_path / "run" / "tracks.npz")
    assert tracks["active"].tolist() == series["active"]
    assert tracks["links_mean"].tolist() == series["links_mean"]
    assert len(tracks["time_s"]) == tracks["position_enu_m"].shape[0]
    # a range shorter than their 5 m: never linked
    short = hop_scenario(hop_module)
    short = parse_scenario(short.text.replace("link_range_m: 8.0", "link_range_m: 4.0"))
    none = run_swarm(short, seed=0)
    assert none["vehicles"]["vehicle1"]["links_total"]["value"] == 0
    assert none["fleet"]["links_per_step_mean"]["value"] == 0.0
    assert "series" not in none  # no run directory: no series in the report


def test_packs_drain_by_hover_power_airborne_plus_loads(hop_module):
    """Energy = hover power x airborne time + loads x run time; charge used matches that energy."""
    report = run_swarm(hop_scenario(hop_module), seed=0)
    v1 = report["vehicles"]["vehicle1"]
    sim_s = report["sim_time_s"]
    loads_w = sum(LOAD_PRESETS["seed000_companion"].values())
    expected_j = hover_power_w() * v1["airborne_time"]["value"] + loads_w * sim_s
    assert v1["energy"]["value"] == pytest.approx(expected_j, rel=1e-9)
    # the charge that energy took from the 5400 mAh 4S pack: between E / (C V_oc(full)) and
    # E / (C V_loaded(end))
    pack = load_power_spec(load_airframe(AIRFRAME).yaml_path).battery
    used = 1.0 - v1["battery_remaining"]["value"] / 100.0
    soc_end = 1.0 - used
    current_a = (hover_power_w() + loads_w) / float(pack.ocv_v(soc_end))
    low_v = float(pack.ocv_v(soc_end)) - 1.2 * current_a * pack.resistance_ohm
    assert expected_j / (pack.capacity_c * float(pack.ocv_v(1.0))) <= used
    assert used <= expected_j / (pack.capacity_c * low_v)
    assert report["fleet"]["battery_remaining_min"]["value"] == pytest.approx(
        100.0 * (1.0 - used), rel=1e-12
    )
    # what the program saw: full at the start, the report's remaining (less) by its last decision
    companion = v1["companion"]
    assert companion["battery_first"]["value"] == 100.0
    assert v1["battery_remaining"]["value"] < companion["battery_last"]["value"] < 100.0
    assert report["warnings"] == []


def test_a_half_capacity_pack_uses_twice_the_share(hop_module):
    """Per-vehicle capacity: the same flight takes twice the share of a pack half the size."""
    report = run_swarm(
        hop_scenario(
            hop_module, battery_capacity_mah=[5400.0, 2700.0], traits={"decision": [1, 2]}
        ),
        seed=0,
    )
    v1, v2 = report["vehicles"]["vehicle1"], report["vehicles"]["vehicle2"]
    assert v1["energy"]["value"] == pytest.approx(v2["energy"]["value"], rel=1e-12)
    used1 = 100.0 - v1["battery_remaining"]["value"]
    used2 = 100.0 - v2["battery_remaining"]["value"]
    assert used2 / used1 == pytest.approx(2.0, rel=0.02)  # a little more: the fuller sag
    assert report["fleet"]["battery_remaining_min"]["value"] == v2["battery_remaining"]["value"]
    assert v2["companion"]["fleet_capacity_mah"]["value"] == 2700.0
    assert v2["companion"]["decision_trait"]["value"] == 2.0


def test_a_pack_too_small_clamps_at_zero_and_warns(hop_module):
    report = run_swarm(hop_scenario(hop_module, battery_capacity_mah=50.0), seed=0)
    assert report["fleet"]["battery_remaining_min"]["value"] == 0.0
    assert any("low-voltage cutoff" in w for w in report["warnings"])


def test_same_seed_same_report(hop_module):
    a = run_swarm(hop_scenario(hop_module), seed=3)
    b = run_swarm(hop_scenario(hop_module), seed=3)
    drop = ("wall", "wall_time_s", "real_time_factor")
    assert json.dumps({k: v for k, v in a.items() if k not in drop}, sort_keys=True) == (
        json.dumps({k: v for k, v in b.items() if k not in drop}, sort_keys=True)
    )


def test_engine_counts_links_of_airborne_vehicles_within_range():
    """Three airborne (two 5 m apart, one 300 m off) and a grounded one next to them."""
    xs = np.array([0.0, 5.0, 300.0, 2.0])
    fleet = KinematicFleet(
        np.column_stack((xs, 0 * xs, 0 * xs)), load_kinematic_limits("typhoon_h480")
    )
    engine = SwarmEngine(
        fleet, [f"n{i}" for i in range(4)], 10, 1, 2, math.inf, np.full(4, np.nan), [],
        link_range_m=20.0,
    )  # fmt: skip
    for i in range(3):
        fleet.takeoff(i, 10.0)
    engine.run(10.0)
    assert engine.links_total.tolist() == [10, 10, 0, 0]  # decisions at 0, 1, ..., 9 s
    assert engine.series_active == [3] * 11  # and the end-of-run sample at 10 s
    assert engine.series_links_mean[0] == pytest.approx(2.0 / 3.0)
    assert engine.stats.link_decisions == 10
    assert math.isnan(engine.handles[0].battery_remaining_pct)  # no battery model given
