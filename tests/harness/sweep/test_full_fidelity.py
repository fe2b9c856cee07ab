"""A full-fidelity trial: the scenario flown as `swarmsitl run` flies it, in its own run dir."""

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from harness.sweep.runner import run_sweep
from harness.sweep.spec import plan_sweep
from harness.sweep.table import RESULTS_FILE

pytestmark = pytest.mark.heavy

HOP = Path(__file__).parents[1] / "scenarios" / "hop.yaml"


@pytest.mark.slow
def test_a_full_fidelity_trial_runs_the_scenario_in_its_run_directory(tmp_path):
    sweep = tmp_path / "hop_sweep.yaml"
    sweep.write_text(
        f"scenario: {HOP}\ngrid:\n  roles.hop.args.altitude_m: [4]\nseeds: [1]\n"
        "trial_timeout_s: 600\n"
    )
    plan = plan_sweep(sweep)
    assert plan.fidelity == "full"
    summary = run_sweep(plan, tmp_path / "out", workers=1)
    (row,) = pq.read_table(tmp_path / "out" / RESULTS_FILE).to_pylist()
    assert row["status"] == "ok", row["error"]
    assert summary.ok == 1
    report = json.loads((tmp_path / "out" / "runs" / row["trial_id"] / "report.json").read_text())
    assert report["seed"] == 1
    assert row["passed"] is report["passed"]
    assert row["fleet.min_separation"] == pytest.approx(report["fleet"]["min_separation"]["value"])
    assert row["sim_time_s"] == pytest.approx(report["sim_time_s"])
