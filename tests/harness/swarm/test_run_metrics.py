"""A role module's ``run_metrics(env, report)``: in the report, checkable, a sweep column."""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml
from distributed import Client, LocalCluster

from harness.scenarios.runner import finish_report
from harness.scenarios.spec import parse_scenario
from harness.swarm.run import run_swarm
from harness.sweep.runner import run_sweep
from harness.sweep.spec import plan_sweep
from harness.sweep.table import RESULTS_FILE, unit_of

PROGRAM = """
def swarm_program(env, vehicle, node):
    return Idle()


class Idle:
    '''Stays on the ground; done at once.'''

    error = None
    done = True

    def decide(self, now_s):
        pass

    def metrics(self):
        return {"ones": (1, "count")}


def run_metrics(env, report):
    if env.params.get("explode"):
        raise RuntimeError("run metrics failed on purpose")
    return {
        "speed_echo": (env.params["speed"] * 2, "m/s"),
        "ones_seen": (report["fleet"]["companions"]["ones"]["value"], "count"),
        "vehicles_told": (len(env.fleet), "count"),
        "seed_echo": (env.seed, "1"),
        "nothing": (None, "s"),
    }
"""

OTHER = """
from run_metrics_role import Idle


def swarm_program(env, vehicle, node):
    return Idle()


def run_metrics(env, report):
    return {"seed_echo": (env.seed + 100, "1"), "other_only": (env.role_count, "count")}
"""


@pytest.fixture
def role_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "run_metrics_role.py").write_text(PROGRAM)
    (tmp_path / "run_metrics_other.py").write_text(OTHER)
    monkeypatch.syspath_prepend(str(tmp_path))
    return "run_metrics_role"


def scenario_data(module: str, fidelity: str = "swarm", **args: object) -> dict:
    """Three idle vehicles of one role, a short run."""
    return {
        "name": "probe",
        "fidelity": fidelity,
        "duration_s": 5,
        "fleet": [{"role": "probe", "count": 3}],
        "roles": {"probe": {"module": module, "args": {"speed": 3.0, **args}}},
        "checks": {"metrics": {"fleet.run.speed_echo": [5.0, 7.0]}},
    }


def test_run_metrics_reach_the_report_and_its_metric_checks(role_module):
    """Told the role's args, the fleet and the seed; sees the companions' totals; checked."""
    report = run_swarm(parse_scenario(yaml.safe_dump(scenario_data(role_module))), seed=4)
    run = report["fleet"]["run"]
    assert run["speed_echo"] == {"value": 6.0, "unit": "m/s"}
    assert run["ones_seen"] == {"value": 3, "unit": "count"}
    assert run["vehicles_told"]["value"] == 3
    assert run["seed_echo"]["value"] == 4
    assert run["nothing"] == {"value": None, "unit": "s"}
    assert report["checks"]["run_metrics"]["ok"]
    assert report["checks"]["metric fleet.run.speed_echo"]["ok"]
    assert report["passed"], report["checks"]


def test_a_raising_run_metrics_warns_and_fails_its_check_but_keeps_the_report(role_module):
    data = scenario_data(role_module, explode=True)
    report = run_swarm(parse_scenario(yaml.safe_dump(data)), seed=0)
    check = report["checks"]["run_metrics"]
    assert not check["ok"]
    assert "RuntimeError: run metrics failed on purpose" in check["message"]
    assert any("run_metrics_role.run_metrics" in w for w in report["warnings"])
    assert report["fleet"]["run"] == {}
    assert not report["checks"]["metric fleet.run.speed_echo"]["ok"]  # not in the report
    assert not report["passed"]
    assert report["vehicles"]["vehicle3"]["companion"]["ones"]["value"] == 1
    assert report["fleet"]["companions"]["ones"]["value"] == 3


def test_a_name_two_roles_report_is_kept_per_role(role_module):
    data = scenario_data(role_module)
    data["fleet"].append({"role": "other", "count": 2})
    data["roles"]["other"] = {"module": "run_metrics_other"}
    report = run_swarm(parse_scenario(yaml.safe_dump(data)), seed=1)
    run = report["fleet"]["run"]
    assert run["probe"]["seed_echo"]["value"] == 1
    assert run["other"]["seed_echo"]["value"] == 101
    assert "seed_echo" not in run
    assert run["other_only"]["value"] == 2
    assert run["speed_echo"]["value"] == 6.0


def test_full_fidelity_reports_get_the_same_run_metrics(role_module):
    """The full stack's report assembly (``finish_report``) on a report as a run writes it."""
    scenario = parse_scenario(yaml.safe_dump(scenario_data(role_module, fidelity="full")))
    env = run_env(scenario)
    report = {
        "complete": True,
        "vehicles": {f"vehicle{i}": {"companion": {"ones": {"value": 1, "unit": "count"}}}
                     for i in (1, 2, 3)},
        "fleet": {"min_separation": {"value": 4.0, "unit": "m"}},
        "checks": {"landed_and_disarmed": {"ok": True, "value": 0, "message": ""}},
        "warnings": [],
    }  # fmt: skip
    finish_report(report, scenario, {"probe": env})
    assert report["fleet"]["companions"]["ones"]["value"] == 3
    assert report["fleet"]["run"]["ones_seen"]["value"] == 3
    assert report["fleet"]["run"]["speed_echo"]["value"] == 6.0
    assert report["checks"]["metric fleet.run.speed_echo"]["ok"]
    assert report["passed"]
    broken = parse_scenario(
        yaml.safe_dump(scenario_data(role_module, fidelity="full", explode=True))
    )
    report.pop("checks")
    finish_report(report, broken, {"probe": run_env(broken)})
    assert not report["checks"]["run_metrics"]["ok"]
    assert not report["passed"]


def run_env(scenario):
    """A role's environment as the full-stack runner describes its first vehicle."""
    from companion.scenario_env import ScenarioEnv

    return ScenarioEnv(
        mavlink_url="udpin://0.0.0.0:1", grpc_port=1, vehicle=1, vehicles=3, role="probe",
        role_index=0, role_count=3, seed=0, out_dir=Path("."),
        params=dict(scenario.spec.roles["probe"].args), fleet=scenario.fleet_entries(),
    )  # fmt: skip


@pytest.mark.process  # Dask's in-process cluster binds sockets and runs `uname`
def test_a_sweep_table_has_a_column_per_run_metric(role_module, tmp_path):
    scenario = tmp_path / "probe.yaml"
    scenario.write_text(yaml.safe_dump(scenario_data(role_module)))
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(f"scenario: {scenario}\ngrid:\n  roles.probe.args.speed: [3.0, 4.0]\n")
    plan = plan_sweep(sweep)
    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,  # in this process: the role module in tmp_path imports there too
        Client(cluster) as client,
    ):
        summary = run_sweep(plan, tmp_path / "out", client=client, plots=False)
    assert summary.ok == 2
    table = pq.read_table(tmp_path / "out" / RESULTS_FILE)
    rows = table.to_pylist()
    assert [r["fleet.run.speed_echo"] for r in rows] == [6.0, 8.0]
    assert unit_of(table, "fleet.run.speed_echo") == "m/s"
    assert [r["fleet.run.nothing"] for r in rows] == [None, None]
    assert unit_of(table, "fleet.run.nothing") == "s"
    assert [r["passed"] for r in rows] == [True, False]  # 8 m/s is out of the bounds
    assert rows[1]["failed_checks"] == "metric fleet.run.speed_echo"
