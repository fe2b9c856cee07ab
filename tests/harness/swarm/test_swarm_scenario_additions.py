"""Scenario-level additions: priorities, the swarm speed and turn caps, ``checks.max_collisions``
at swarm fidelity, and the full stack's truth-based collision counter on synthetic tracks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from harness.report.collisions import airframe_diameter_m, count_from_tracks, tracks_on_grid
from harness.report.flight_log import IN_AIR, ON_GROUND, FlightLog, Track, VehicleLog
from harness.scenarios.spec import ScenarioError, SwarmSpec, parse_scenario
from harness.swarm.run import run_swarm, scenario_limits
from sitl.kinematic_fleet import KinematicFleet
from sitl.vehicles.kinematics import KinematicLimits
from worlds.model import Solid
from worlds.solid_set import SolidSet

LIMITS = KinematicLimits(12.0, 3.0, 45.0, 3.0, 1.5, 4.0)

RAMMER = """
import numpy as np


def swarm_program(env, vehicle, node):
    return Rammer(vehicle)


class Rammer:
    '''Take off to 5 m, fly to the other vehicle's start at 3 m/s, land at 20 s.'''

    error = None

    def __init__(self, vehicle):
        self.vehicle = vehicle
        self.landing = False

    @property
    def done(self):
        return self.landing and not self.vehicle.airborne

    def decide(self, now_s):
        v = self.vehicle
        if now_s == 0.0:
            v.takeoff(5.0)
        elif now_s == 5.0:
            other = 1 - v.index
            home = v.home_enu_m
            v.goto(np.array([home[0] + (10.0 if other else -10.0), home[1], 5.0]), 3.0)
        elif now_s >= 20.0 and not self.landing:
            v.land()
            self.landing = True

    def metrics(self):
        return {"priority": (self.vehicle.priority, "")}
"""


def scenario_yaml(module: str, **extra) -> str:
    spec = {
        "name": "rammers",
        "fidelity": "swarm",
        "swarm": {"step_hz": 20, "decision_hz": 1},
        "duration_s": 40,
        "fleet": [{"role": "ram", "count": 2, "airframe": "typhoon_h480_yuneec",
                   "start_enu_m": [[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]]}],
        "roles": {"ram": {"module": module}},
        "checks": {"max_collisions": 0},
    } | extra  # fmt: skip
    return yaml.safe_dump(spec)


@pytest.fixture
def rammer(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "swarm_rammer_role.py").write_text(RAMMER)
    monkeypatch.syspath_prepend(str(tmp_path))
    return "swarm_rammer_role"


def test_max_collisions_zero_fails_a_run_with_a_collision(rammer):
    report = run_swarm(parse_scenario(scenario_yaml(rammer)), seed=1)
    fleet = report["fleet"]
    assert fleet["collisions"]["value"] == fleet["collisions_vehicle"]["value"] == 1
    assert fleet["collisions_solid"]["value"] == 0
    assert [e["a"] for e in fleet["collision_events"]["value"]] == ["vehicle1"]
    assert report["vehicles"]["vehicle2"]["collisions"]["value"] == 1
    check = report["checks"]["max_collisions"]
    assert not check["ok"] and check["value"] == 1
    assert not report["passed"]
    assert report["vehicles"]["vehicle2"]["companion"]["priority"]["value"] == 2


def test_priority_defaults_to_the_vehicle_number_or_follows_the_group():
    text = scenario_yaml("x")
    entries = parse_scenario(text).fleet_entries()
    assert [e["priority"] for e in entries] == [1, 2]
    data = yaml.safe_load(text)
    data["fleet"][0]["priority"] = [5, 3]
    data["fleet"].append({"role": "ram", "count": 2, "priority": 9})
    entries = parse_scenario(yaml.safe_dump(data)).fleet_entries()
    assert [e["priority"] for e in entries] == [5, 3, 9, 9]
    data["fleet"][0]["priority"] = [1]
    with pytest.raises(ScenarioError, match="priority has 1 values for count 2"):
        parse_scenario(yaml.safe_dump(data))


def test_the_swarm_caps_limit_speed_and_turn_under_the_airframes():
    capped = scenario_limits(LIMITS, SwarmSpec(max_speed_m_s=6.0, max_turn_rate_deg_s=30.0))
    assert (capped.max_speed_m_s, capped.max_turn_rate_deg_s) == (6.0, 30.0)
    loose = scenario_limits(LIMITS, SwarmSpec(max_speed_m_s=50.0, max_turn_rate_deg_s=90.0))
    assert loose == LIMITS
    fleet = KinematicFleet(np.zeros((1, 3)), capped)
    fleet.takeoff(0, 10.0)
    square = np.array([[60, 0, 10], [60, 60, 10], [0, 60, 10], [0, 0, 10]], dtype=float)
    fleet.set_path(0, square, 12.0)
    speeds, courses, dt = [], [], 0.05
    for _ in range(round(120 / dt)):
        speeds.append(fleet.state.speed_m_s[0])
        courses.append(fleet.state.course_rad[0])
        fleet.step(dt)
    assert max(speeds) <= 6.0 + 1e-9 and max(speeds) > 5.9
    turn = np.degrees(np.abs(np.angle(np.exp(1j * np.diff(courses))))) / dt
    moving = np.array(speeds[:-1]) >= 0.5
    assert turn[moving].max() <= 30.0 + 1e-6 and turn[moving].max() > 20.0
    assert fleet.path_done()[0]


def test_the_airframe_diameter_is_rotor_tip_to_tip():
    # Typhoon H480: hubs 0.2477 m from the centre, 0.2286 m rotors
    assert airframe_diameter_m("typhoon_h480") == pytest.approx(2 * 0.2477 + 0.2286, abs=1e-3)


def _synthetic_log() -> FlightLog:
    """Two vehicles 10 Hz: they meet twice in the air (apart between) and once on the ground."""
    t = np.arange(0.0, 30.0, 0.1)
    x1 = np.where(t < 10, 0.0, np.where(t < 20, 5.0, 0.0))
    # vehicle 1 rests at 0 / 5 m east; vehicle 2 sweeps past it twice at 0.2 m
    x2 = 10.0 - t % 10.0 * 1.0  # 10 -> 0 each 10 s
    landed = np.where(t < 20, IN_AIR, ON_GROUND)
    vehicles = []
    for i, x in enumerate((x1, x2)):
        cols = {
            "time_s": t, "east_m": x, "north_m": np.full_like(t, 0.2 * i),
            "up_m": np.full_like(t, 5.0), "landed_state": landed.astype(float),
        }  # fmt: skip
        vehicles.append(VehicleLog(i, Track(cols)))
    return FlightLog(Path("."), vehicles)


def test_the_truth_counter_counts_contact_events_of_airborne_tracks():
    """Two passes in the air count two events; the third, on the ground, none; a box once."""
    time_s, pos, up = tracks_on_grid(_synthetic_log())
    assert pos.shape == (300, 2, 3) and up[:200].all() and not up[200:].any()
    counter = count_from_tracks(time_s, pos, up, np.full(2, 0.25), None)
    assert (counter.total, counter.vehicle_events) == (2, 2)
    assert counter.per_vehicle.tolist() == [2, 2]
    assert [round(e["time_s"]) for e in counter.events] == [10, 15]  # x2 meets 0 near 10 s, 5 at 15
    box = SolidSet([Solid("box", "box", (7.0, 0.0, 2.0), (1.0, 4.0, 4.0))])  # top at 4 m
    counter = count_from_tracks(time_s, pos, up, np.full(2, 0.25), box)
    assert counter.solid_events == 0  # both fly at 5 m, 0.75 m above its top
    counter = count_from_tracks(time_s, pos, up, np.full(2, 1.5), box)
    assert counter.solid_events == 2  # vehicle 2 crosses x = 7 twice while airborne
