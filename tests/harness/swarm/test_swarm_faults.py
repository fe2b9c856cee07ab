"""Faults at swarm fidelity: a crash grounds a vehicle for good, a radio fault silences its node.

Three vehicles hover side by side and ping each other every decision; the scenario crashes
vehicle 2 and takes vehicle 3's transmitter, and a fault due after the run ends is reported as not
applied. Each program records when it last heard each peer and whether its commands were obeyed.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from harness.scenarios.spec import parse_scenario
from harness.swarm.run import run_swarm

PROGRAM = """
def swarm_program(env, vehicle, node):
    return Chatter(env, vehicle, node)


class Chatter:
    '''Hover at 5 m, ping every decision, land at 20 s; remember when each peer was heard.'''

    error = None

    def __init__(self, env, vehicle, node):
        self.vehicle, self.node = vehicle, node
        self.heard = {}
        self.landing = False
        self.last_decision = 0.0

    @property
    def done(self):
        return self.landing and not self.vehicle.airborne

    def decide(self, now_s):
        self.last_decision = now_s
        for env in self.node.poll():
            self.heard[env.src] = now_s
        self.node.broadcast("ping", {"t": now_s})
        if now_s == 0.0:
            self.vehicle.takeoff(5.0)
        elif now_s >= 20.0 and not self.landing:
            self.vehicle.land()
            self.landing = True

    def metrics(self):
        out = {f"heard_{k}": (v, "s") for k, v in sorted(self.heard.items())}
        return out | {"last_decision": (self.last_decision, "s")}
"""


@pytest.fixture
def chatter(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "swarm_chatter_role.py").write_text(PROGRAM)
    monkeypatch.syspath_prepend(str(tmp_path))
    return "swarm_chatter_role"


def scenario(module: str, faults: list[dict]):
    spec = {
        "name": "chatter",
        "fidelity": "swarm",
        "swarm": {"step_hz": 10, "decision_hz": 1, "neighbours": 2},
        "duration_s": 60,
        "spacing_m": 5,
        "fleet": [{"role": "chat", "count": 3, "airframe": "typhoon_h480_yuneec"}],
        "roles": {"chat": {"module": module}},
        "checks": {"landed_and_disarmed": True},
        "faults": faults,
    }
    return parse_scenario(yaml.safe_dump(spec))


def test_a_crash_grounds_the_vehicle_and_a_radio_fault_silences_its_node(chatter):
    faults = [
        {"kind": "crash", "vehicle": 2, "at_s": 5.0},
        {"kind": "radio_tx", "vehicle": 3, "at_s": 8.05},
        {"kind": "crash", "vehicle": 2, "at_s": 9.0},  # lost already: dropped, reported once
        {"kind": "land", "vehicle": 1, "at_s": 59.0},  # after the run has ended
    ]
    report = run_swarm(scenario(chatter, faults), seed=1)
    assert report["passed"], report["checks"]
    assert report["faults"] == [
        {"vehicle": "vehicle2", "kind": "crash", "time_s": 5.0, "due_s": 5.0, "entry": 0,
         "applied": True},
        {"vehicle": "vehicle3", "kind": "radio_tx", "time_s": 8.1, "due_s": 8.05, "entry": 1,
         "applied": True},
        {"vehicle": "vehicle1", "kind": "land", "time_s": None, "due_s": 59.0, "entry": 3,
         "applied": False},
    ]  # fmt: skip
    v1, v2, v3 = (report["vehicles"][f"vehicle{k}"] for k in (1, 2, 3))
    assert v2["fault"] == "crash" and v3["fault"] == "radio_tx" and "fault" not in v1
    # the crashed vehicle stopped flying at 5 s and stayed down (its land at 20 s changed
    # nothing), while its program went on deciding until it thought itself landed, at 20 s
    assert v2["airborne_time"]["value"] == pytest.approx(5.0, abs=0.11)
    assert v1["airborne_time"]["value"] > 20.0
    assert v2["landed"]["value"] is True
    c1, c2, c3 = (v["companion"] for v in (v1, v2, v3))
    assert c2["last_decision"]["value"] == 20.0 < c1["last_decision"]["value"]
    # vehicle 3 is heard until its transmitter fails (its ping of 8 s read at 9 s), and hears on;
    # the crashed vehicle's radio works on
    assert c1["heard_vehicle3"]["value"] == c2["heard_vehicle3"]["value"] == 9.0
    assert c3["heard_vehicle1"]["value"] == c1["last_decision"]["value"]
    assert c1["heard_vehicle2"]["value"] == 21.0  # its last ping, at 20 s, long after its crash
    assert report["fleet"]["datagrams_dropped_by_faults"]["value"] > 0


def test_the_same_seed_draws_the_same_fraction_whatever_the_programs(chatter):
    faults = [{"kind": ["crash", "radio"], "fraction": 0.5, "between_s": [2.0, 15.0]}]
    a = run_swarm(scenario(chatter, faults), seed=7)["faults"]
    b = run_swarm(scenario(chatter, faults), seed=7)["faults"]
    assert a == b and len(a) in (1, 2)
    assert all(2.0 <= f["time_s"] <= 15.1 and f["kind"] == "crash+radio" for f in a)


LANDER = """
def swarm_program(env, vehicle, node):
    return Again(vehicle)


class Again:
    '''Take off; if something lands it, take off again at 12 s; land for good at 20 s.'''

    error = None

    def __init__(self, vehicle):
        self.vehicle = vehicle
        self.heights = {}
        self.finished = False

    @property
    def done(self):
        return self.finished and not self.vehicle.airborne

    def decide(self, now_s):
        self.heights[now_s] = float(self.vehicle.position_enu_m[2])
        if now_s in (0.0, 12.0) and not self.vehicle.airborne:
            self.vehicle.takeoff(5.0)
        elif now_s >= 20.0 and not self.finished:
            self.vehicle.land()
            self.finished = True

    def metrics(self):
        return {"h10": (self.heights[10.0], "m"), "h18": (self.heights[18.0], "m")}
"""


def test_a_land_fault_lands_the_vehicle_and_a_later_command_flies_it_again(tmp_path, monkeypatch):
    (tmp_path / "swarm_again_role.py").write_text(LANDER)
    monkeypatch.syspath_prepend(str(tmp_path))
    s = scenario("swarm_again_role", [{"kind": "land", "vehicle": 1, "at_s": 4.0}])
    report = run_swarm(s, seed=0)
    assert report["passed"], report["checks"]
    v1, v2 = report["vehicles"]["vehicle1"], report["vehicles"]["vehicle2"]
    assert v1["fault"] == "land" and report["faults"][0]["time_s"] == 4.0
    assert v1["companion"]["h10"]["value"] < 0.1 < 4.0 < v1["companion"]["h18"]["value"]
    assert v2["companion"]["h10"]["value"] > 4.0  # the others fly on
