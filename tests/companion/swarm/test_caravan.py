"""The caravan role (seed 003) at swarm fidelity: allocation over the radio, flight, landing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from companion.scenario_env import ScenarioEnv
from companion.scripts.caravan import run_metrics
from companion.swarm.caravan import CaravanProgram
from harness.scenarios.spec import parse_scenario
from harness.swarm.run import run_swarm

WORLD = {
    "kind": "taskmap",
    "seed": 3,
    "size_m": [10, 10],
    "grid_spacing_m": 0.5,
    "task_count": 5,
    "agent_count": 5,
}


def _scenario(algorithm: str, tmp_path: Path) -> object:
    spec = {
        "name": f"caravan-{algorithm}",
        "fidelity": "swarm",
        "seed": 3,
        "duration_s": 90,
        "world": WORLD,
        "fleet": [{"role": "caravan", "count": 5, "airframe": "x500"}],
        "roles": {
            "caravan": {"module": "companion.scripts.caravan", "args": {"algorithm": algorithm}}
        },
        "sensors": {"cameras": False, "rangefinders": False},
        "swarm": {"step_hz": 20, "decision_hz": 5},
        "checks": {"landed_and_disarmed": True, "companions_succeeded": True},
    }
    return parse_scenario(yaml.safe_dump(spec), "caravan.yaml", tmp_path)


@pytest.mark.parametrize("algorithm", ["icf", "gbaa", "ica"])
def test_five_vehicles_complete_every_task_land_and_learn_each_others_completions(
    algorithm: str, tmp_path: Path
) -> None:
    """Every task completed, every vehicle landed, completions learned over the radio.

    The run's gap (J against J*, the single-assignment optimum from the start points on the
    lattice) is below 1 but not above 0: on this map vehicle 5 starts beside a cluster of three
    tasks and, free again after the first, completes the other two sooner than the vehicles J*
    sends there could (measured -0.11 for ICF): J* is no upper bound of J when agents re-bid.
    """
    report = run_swarm(_scenario(algorithm, tmp_path), run_dir=tmp_path / "run")
    assert report["passed"], report["checks"]
    values = [
        {k: v["value"] for k, v in veh["companion"].items()} for veh in report["vehicles"].values()
    ]
    done = sorted(j for v in values for j, _ in v["completions"])
    assert set(done) == set(range(5))
    # each vehicle knows all 5 tasks completed, most of them done by others: heard, not seen
    assert all(v["tasks_validated"] == 5 for v in values)
    assert all(v["phase"] == "done" for v in values)
    assert report["fleet"]["datagrams_delivered"]["value"] > 0
    env = ScenarioEnv(
        mavlink_url="swarm://", grpc_port=0, vehicle=1, vehicles=5, role="caravan",
        role_index=0, role_count=5, seed=3, out_dir=tmp_path, world=tmp_path / "run" / "world.yaml",
        params={"algorithm": algorithm},
    )  # fmt: skip
    figures = run_metrics(env, report)
    gap = figures["optimality_gap"][0]
    assert -0.2 < gap < 1.0, figures
    assert figures["score"][0] > 0.8 * figures["optimal_score"][0]
    assert figures["tasks_validated"] == (5, "count")
    assert figures["tasks_total"] == (5, "count")
    assert figures["execution_time"][0] > 0.0
    assert figures["convergence_steps"][0] >= 1
    assert figures["tasks_completed_twice"][0] == 0


class _FakeVehicle:
    """A kinematic vehicle that climbs at once and can be brought down."""

    index = 0
    node_id = "vehicle1"

    def __init__(self) -> None:
        self.time_s = 0.0
        self.airborne = False
        self.position_enu_m = np.zeros(3)
        self.home_enu_m = np.zeros(3)
        self.path_done = True
        self.paths: list[np.ndarray] = []

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        self.airborne = True
        self.position_enu_m = np.array([0.0, 0.0, height_m])

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        self.paths.append(np.asarray(waypoints_enu_m))

    def land(self) -> None:
        self.airborne = False


def test_a_vehicle_brought_down_ends_the_program_quietly(tmp_path: Path) -> None:
    """Once its vehicle is on the ground unexpectedly the program is done, without an error,
    and sends nothing more."""
    world = tmp_path / "world.yaml"
    world.write_text(yaml.safe_dump(WORLD))
    env = ScenarioEnv(
        mavlink_url="swarm://", grpc_port=0, vehicle=1, vehicles=5, role="caravan",
        role_index=0, role_count=5, seed=3, out_dir=tmp_path, world=world, params={},
    )  # fmt: skip
    v = _FakeVehicle()
    program = CaravanProgram(env, v, None)
    program.decide(0.0)
    program.decide(0.2)
    assert program.phase == "mission" and v.paths  # climbed, flying to a task
    v.airborne = False  # a fault
    program.decide(0.4)
    steps = program.allocator.stats.steps
    program.decide(0.6)
    assert program.done and program.phase == "down" and program.error is None
    assert program.allocator.stats.steps == steps
    assert program.metrics()["phase"] == ("down", "name")
