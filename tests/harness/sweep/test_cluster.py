"""Sweeps on a separately started ``dask scheduler`` + ``dask worker`` processes."""

from pathlib import Path

import pyarrow.parquet as pq
import pytest
import trial_bodies
from dask_processes import dask_cluster
from distributed import Client
from typer.testing import CliRunner

from harness.cli import app
from harness.commands.sweep import EXIT_CHECKS_FAILED
from harness.sweep.runner import run_sweep
from harness.sweep.spec import plan_sweep
from harness.sweep.table import RESULTS_FILE

pytestmark = pytest.mark.heavy

DATA = Path(__file__).with_name("data")


def test_a_lost_workers_trials_run_elsewhere_and_are_counted(tmp_path):
    sweep = tmp_path / "grid.yaml"
    sweep.write_text(
        f"scenario: {DATA / 'tiny.yaml'}\ngrid:\n  fleet.0.count: [1, 2, 3]\nseeds: 2\n"
    )
    plan = plan_sweep(sweep)
    marker = tmp_path / "killed.pid"
    env = {trial_bodies.KILL_MARKER_ENV: str(marker)}
    with (
        dask_cluster(tmp_path, workers=2, nanny=False, env=env) as (address, workers),
        Client(address) as client,
    ):
        summary = run_sweep(plan, tmp_path / "out", client=client, execute=trial_bodies.dies_once)
        killed = int(marker.read_text())
        assert killed in [w.pid for w in workers]
        assert [w.poll() is not None for w in workers].count(True) == 1  # one worker died
        survivor = next(iter(client.scheduler_info()["workers"]))
    assert (summary.ok, summary.failed) == (6, 0)
    assert summary.retried >= 1
    rows = pq.read_table(tmp_path / "out" / RESULTS_FILE).to_pylist()
    retried = [r for r in rows if r["retries"] > 0]
    assert len(retried) == summary.retried
    assert sum(r["retries"] for r in rows) == summary.retries
    assert all(r["retries"] == 1 for r in retried)
    assert all(r["worker"] == survivor for r in retried)
    assert all(r["status"] == "ok" for r in rows)


def test_swarmsitl_sweep_runs_on_a_dask_scheduler_and_two_dask_workers(tmp_path):
    """The issue's done-when: the same sweep file against `dask scheduler` + 2 `dask worker`."""
    out = tmp_path / "out"
    with dask_cluster(tmp_path, workers=2) as (address, _):
        result = CliRunner().invoke(
            app,
            ["sweep", str(DATA / "small_coverage.yaml"), "--scheduler", address, "--out", str(out)],
        )
    # at 60 s the 4-vehicle fleet's companions have no time to fly their strips: they fail the
    # scenario's companions_succeeded check, which the summary and the exit status report
    assert result.exit_code == EXIT_CHECKS_FAILED, result.output
    output = " ".join(result.output.split())
    assert "results: 2 passed, 2 failed checks, 0 errored, 0 not run (of 4 trials)" in output
    assert "this run: 4 finished, 0 errored, 0 skipped" in output
    rows = pq.read_table(out / RESULTS_FILE).to_pylist()
    assert [(r["fleet.0.count"], r["seed"]) for r in rows] == [(1, 0), (1, 1), (4, 0), (4, 1)]
    assert all(r["status"] == "ok" and r["duration_s"] == 60 for r in rows)
    assert len({r["worker"] for r in rows}) == 2
    assert all(r["fleet.vehicles"] == r["fleet.0.count"] for r in rows)
    assert [r["passed"] for r in rows] == [True, True, False, False]
    assert {r["failed_checks"] for r in rows if not r["passed"]} == {"companions_succeeded"}
    for metric in ("fleet.companions.coverage_fraction", "fleet.energy"):
        assert (out / "plots" / f"{metric}.png").stat().st_size > 10_000
