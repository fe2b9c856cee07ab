"""``fidelity: swarm``: the engine, its report, determinism, messaging, events and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from harness.cli import app
from harness.scenarios import scenario_path
from harness.scenarios.spec import ScenarioError, parse_scenario
from harness.swarm.engine import poisson_events
from harness.swarm.run import run_swarm

WALL_KEYS = ("wall", "wall_time_s", "real_time_factor", "run_dir")


def scenario(count: int = 8, duration_s: float = 150.0, **changes: object):
    spec = yaml.safe_load(scenario_path("swarm_coverage").read_text())
    spec["fleet"][0]["count"] = count
    spec["duration_s"] = duration_s
    spec["roles"]["survey"]["args"]["area_enu_m"] = [0, 10, 300, 310]
    spec["swarm"]["event_rate_hz"] = 0.02
    spec.update(changes)
    return parse_scenario(
        yaml.safe_dump(spec), "swarm.yaml", scenario_path("swarm_coverage").parent
    )


def without_wall(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in WALL_KEYS}


def test_a_swarm_run_flies_covers_messages_and_lands(tmp_path: Path) -> None:
    report = run_swarm(scenario(), seed=1, run_dir=tmp_path / "run")
    assert report["passed"], report["checks"]
    assert report["stop_reason"] == "done"  # every program landed before the end
    fleet = report["fleet"]
    companions = fleet["companions"]
    assert companions["coverage_fraction"]["value"] > 0.8
    assert companions["distance_flown_m"]["value"] > 8 * 200.0
    # every node told its neighbours where it was, through the link model (a few % lost)
    assert fleet["datagrams_delivered"]["value"] > 0.9 * fleet["datagrams_submitted"]["value"]
    assert 0 < fleet["message_loss"]["value"] < 10
    assert fleet["message_latency"]["value"] > 0
    assert "edge-edge" in report["net"]["classes"]
    # Poisson events were seen by cameras and shared: what the fleet knows includes what it saw
    assert fleet["targets_seen"]["value"] > 0
    assert companions["targets_known_names"]["value"] >= companions["targets_seen_names"]["value"]
    assert fleet["detection_latency"]["value"] >= 0
    assert fleet["energy"]["value"] > 0
    written = json.loads((tmp_path / "run" / "report.json").read_text())
    assert written["fleet"]["vehicles"]["value"] == 8
    tracks = np.load(tmp_path / "run" / "tracks.npz")
    assert tracks["position_enu_m"].shape[1:] == (8, 3)
    assert (tmp_path / "run" / "plots" / "map.png").stat().st_size > 10_000
    assert "plots/map.png" in written["files"]


def test_same_seed_same_report_other_seed_other_events(tmp_path: Path) -> None:
    a = run_swarm(scenario(), seed=5)
    assert "files" not in a  # no run directory (a sweep's trial): no tracks or plots written
    b = run_swarm(scenario(), seed=5)
    c = run_swarm(scenario(), seed=6)
    assert json.dumps(without_wall(a), sort_keys=True, default=str) == json.dumps(
        without_wall(b), sort_keys=True, default=str
    )
    assert a["fleet"]["targets_appeared"] != c["fleet"]["targets_appeared"] or (
        a["net"] != c["net"]
    )


def test_poisson_events_have_the_rate_and_stay_inside() -> None:
    rng = np.random.default_rng(0)
    counts = [
        len(poisson_events(0.5, 100.0, (0, 0, 10, 10), rng, lambda p: p[:, 0] < 5.0))
        for _ in range(200)
    ]
    assert np.mean(counts) == pytest.approx(50.0, rel=0.05)
    events = poisson_events(0.5, 100.0, (0, 0, 10, 10), rng, lambda p: p[:, 0] < 5.0)
    times = [e.appear_s for e in events]
    assert times == sorted(times) and times[0] >= 0.0 and times[-1] <= 100.0
    assert all(e.xy_m[0] < 5.0 for e in events)
    assert poisson_events(0.0, 100.0, (0, 0, 1, 1), rng) == []


def test_neighbour_tables_list_the_nearest_within_radio_range() -> None:
    from harness.swarm.engine import SwarmEngine
    from sitl.kinematic_fleet import KinematicFleet
    from sitl.vehicles.kinematics import load_kinematic_limits

    xs = np.array([0.0, 10.0, 25.0, 200.0])
    fleet = KinematicFleet(np.column_stack((xs, 0 * xs, 0 * xs)), load_kinematic_limits("x500"))
    ids = [f"n{i}" for i in range(4)]
    engine = SwarmEngine(fleet, ids, 10, 1, 2, 100.0, np.full(4, np.nan), [])
    engine.run(0.1)
    assert engine.neighbour_ids(0) == ["n1", "n2"]
    assert engine.neighbour_ids(2) == ["n1", "n0"]
    assert engine.neighbour_ids(3) == []  # 175 m from the nearest: out of range


PROGRAM = """
def swarm_program(env, vehicle, node):
    return Broken(vehicle)


class Broken:
    error = None
    done = False

    def __init__(self, vehicle):
        self.vehicle = vehicle

    def decide(self, now_s):
        if not self.vehicle.airborne:
            self.vehicle.takeoff(5.0)
        elif self.vehicle.path_done and self.vehicle.index == 0:
            raise RuntimeError("planner crashed")

    def metrics(self):
        return {}
"""


def test_a_failing_program_lands_its_vehicle_and_fails_the_check(tmp_path, monkeypatch) -> None:
    (tmp_path / "broken_swarm_role.py").write_text(PROGRAM)
    monkeypatch.syspath_prepend(str(tmp_path))
    spec = scenario(count=3, duration_s=40.0)
    roles = {"survey": {"module": "broken_swarm_role"}}
    report = run_swarm(scenario(count=3, duration_s=40.0, roles=roles), seed=0)
    assert spec.spec.fidelity == "swarm"
    check = report["checks"]["companions_succeeded"]
    assert not check["ok"] and check["value"] == 1
    assert "planner crashed" in check["message"]
    assert report["vehicles"]["vehicle1"]["landed"]["value"] is True
    assert report["vehicles"]["vehicle2"]["landed"]["value"] is False  # the others fly on
    assert not report["passed"]


def test_roles_without_a_swarm_program_are_named() -> None:
    roles = {"survey": {"module": "companion.scripts.demo_flight"}}
    with pytest.raises(ScenarioError, match="no swarm_program"):
        run_swarm(scenario(count=2, roles=roles))
    roles = {"survey": {"script": "swarm_coverage.yaml"}}
    with pytest.raises(ScenarioError, match="a script or command role has none"):
        run_swarm(scenario(count=2, roles=roles))


def test_what_fidelity_swarm_does_not_model_is_a_warning() -> None:
    checks = {"no_failsafe": True, "companions_succeeded": True}
    report = run_swarm(scenario(count=2, duration_s=30.0, cloud=True, checks=checks), seed=0)
    assert "cloud: fidelity swarm starts no cloud process" in report["warnings"]
    assert any("no_failsafe" in w for w in report["warnings"])
    assert "no_failsafe" not in report["checks"]


def test_bad_swarm_settings_fail_at_load() -> None:
    with pytest.raises(ScenarioError, match="must divide step_hz"):
        scenario(swarm={"step_hz": 10, "decision_hz": 3})
    with pytest.raises(ScenarioError, match="unknown preset"):
        scenario(swarm={"loads": "jetpack"})
    with pytest.raises(ScenarioError, match="fidelity full flies at most 255"):
        scenario(count=300, fidelity="full")
    assert scenario(count=3000).spec.n_vehicles == 3000


def test_swarmsitl_run_runs_a_swarm_scenario(tmp_path: Path) -> None:
    spec = yaml.safe_load(scenario_path("swarm_coverage").read_text())
    spec["fleet"][0]["count"] = 3
    spec["roles"]["survey"]["args"]["area_enu_m"] = [0, 10, 200, 210]
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(spec))
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code == 0, result.output
    assert "fidelity swarm" in result.output
    assert (tmp_path / "out" / "report.json").exists()
    result = CliRunner().invoke(app, ["run", str(path), "--speed", "2"])
    assert result.exit_code == 2
    assert "lockstep only" in result.output
