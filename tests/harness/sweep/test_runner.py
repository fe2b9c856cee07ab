"""Trials on a local Dask cluster: rows as they finish, failures kept, resume, the table, plots."""

from pathlib import Path

import dask
import pyarrow.parquet as pq
import pytest
import trial_bodies
from distributed import Client, LocalCluster

from harness.sweep.runner import SweepOutcome, run_sweep
from harness.sweep.spec import plan_sweep
from harness.sweep.table import RESULTS_FILE, TRIALS_DIR, unit_of

pytestmark = pytest.mark.heavy

DATA = Path(__file__).with_name("data")


@pytest.fixture(scope="module")
def client():
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c


def sweep_file(tmp_path, seeds=2):
    path = tmp_path / "grid.yaml"
    path.write_text(
        f"scenario: {DATA / 'tiny.yaml'}\n"
        "grid:\n  fleet.0.count: [1, 10, 100]\n  roles.survey.args.speed_m_s: [8, 12]\n"
        f"seeds: {seeds}\nmetrics: [fleet.coverage_fraction, fleet.companions.detected]\n"
    )
    return plan_sweep(path)


def test_a_failing_trial_is_recorded_with_its_traceback_and_the_others_finish(tmp_path, client):
    plan = sweep_file(tmp_path)
    out = tmp_path / "out"
    summary = run_sweep(plan, out, client=client, execute=trial_bodies.failing_for_speed_12)
    assert (summary.ok, summary.failed, summary.skipped) == (6, 6, 0)
    table = pq.read_table(out / RESULTS_FILE)
    assert unit_of(table, "fleet.coverage_fraction") == "1"
    assert unit_of(table, "fleet.events") == "count"
    assert unit_of(table, "wall_s") is None
    rows = table.to_pylist()
    assert [r["trial_id"] for r in rows] == [t.trial_id for t in plan.trials]
    for r in rows:
        if r["roles.survey.args.speed_m_s"] == 12:
            assert r["status"] == "failed"
            assert "RuntimeError: trial body failed on purpose at 12 m/s" in r["error"]
            assert "Traceback" in r["error"]
            assert r["fleet.coverage_fraction"] is None
        else:
            assert r["status"] == "ok"
            assert r["error"] == ""
            assert 0 < r["fleet.coverage_fraction"] <= 1.1
        assert r["retries"] == 0
        assert r["worker"].startswith("tcp://")
    assert [p.name for p in summary.plots] == [
        "fleet.coverage_fraction.png",
        "fleet.companions.detected.png",
    ]
    assert all(p.stat().st_size > 10_000 for p in summary.plots)


def test_the_summary_counts_passed_failed_checks_and_errored_over_the_whole_sweep(tmp_path, client):
    """Issue 25: a trial whose checks failed is ``ok`` in status but counted as failed checks."""
    plan = sweep_file(tmp_path)
    out = tmp_path / "out"
    body = trial_bodies.checks_fail_for_speed_12_errors_for_100
    summary = run_sweep(plan, out, client=client, execute=body)
    # counts 1 and 10 x speeds 8 and 12 x 2 seeds ran; count 100 (4 trials) raised
    assert summary.outcome == SweepOutcome(passed=4, checks_failed=4, errored=4, missing=0)
    assert (summary.ok, summary.failed) == (8, 4)
    assert "results: 4 passed, 4 failed checks, 4 errored, 0 not run" in summary.describe()
    rows = pq.read_table(out / RESULTS_FILE).to_pylist()
    failed_checks = [r for r in rows if r["status"] == "ok" and not r["passed"]]
    assert {r["roles.survey.args.speed_m_s"] for r in failed_checks} == {12}
    assert {r["failed_checks"] for r in failed_checks} == {"metric fleet.coverage_fraction"}
    assert {r["trial_id"] for r in summary.failing} == {
        r["trial_id"] for r in rows if r["status"] != "ok" or not r["passed"]
    }
    # a resumed run reruns only the errored trials and still counts the earlier failed checks
    again = run_sweep(plan, out, client=client, execute=trial_bodies.synthetic_report)
    assert (again.ok, again.failed, again.skipped) == (4, 0, 8)
    assert again.outcome == SweepOutcome(passed=8, checks_failed=4, errored=0, missing=0)


def test_trials_left_out_by_max_trials_are_counted_as_not_run(tmp_path, client):
    plan = sweep_file(tmp_path, seeds=1)
    body = trial_bodies.checks_fail_for_speed_12_errors_for_100
    summary = run_sweep(plan, tmp_path / "out", client=client, max_trials=3, execute=body)
    assert summary.outcome == SweepOutcome(passed=2, checks_failed=1, errored=0, missing=3)


def test_a_resumed_sweep_runs_only_what_did_not_finish_ok(tmp_path, client):
    plan = sweep_file(tmp_path)
    out = tmp_path / "out"
    first = run_sweep(plan, out, client=client, execute=trial_bodies.failing_for_speed_12)
    assert (first.ok, first.failed) == (6, 6)
    before = {p.name: p.stat().st_mtime_ns for p in (out / TRIALS_DIR).iterdir()}
    ran = []
    second = run_sweep(
        plan, out, client=client, execute=trial_bodies.synthetic_report, on_row=ran.append
    )
    assert (second.ok, second.failed, second.skipped) == (6, 0, 6)
    assert {r["roles.survey.args.speed_m_s"] for r in ran} == {12}
    after = {p.name: p.stat().st_mtime_ns for p in (out / TRIALS_DIR).iterdir()}
    kept = [n for n in before if before[n] == after[n]]
    assert len(kept) == 6  # the ok rows were not rewritten
    rows = pq.read_table(out / RESULTS_FILE).to_pylist()
    assert len(rows) == 12 and all(r["status"] == "ok" for r in rows)
    third = run_sweep(plan, out, client=client, on_row=ran.append)
    assert (third.ok, third.failed, third.skipped) == (0, 0, 12)
    assert len(ran) == 6


def test_max_trials_runs_a_part_and_the_rest_comes_on_the_next_run(tmp_path, client):
    plan = sweep_file(tmp_path, seeds=1)
    out = tmp_path / "out"
    part = run_sweep(plan, out, client=client, max_trials=2, execute=trial_bodies.synthetic_report)
    assert (part.ok, part.not_run) == (2, 4)
    assert pq.read_table(out / RESULTS_FILE).num_rows == 2
    rest = run_sweep(plan, out, client=client, execute=trial_bodies.synthetic_report)
    assert (rest.ok, rest.skipped, rest.not_run) == (4, 2, 0)
    assert pq.read_table(out / RESULTS_FILE).num_rows == 6


WALL_CLOCK_COLUMNS = ("worker", "wall_s")
"""The only columns that may differ between two runs of the same trial."""


def test_the_same_sweep_on_one_worker_and_on_two_gives_identical_rows(tmp_path, client):
    plan = plan_sweep(DATA / "small_coverage.yaml")
    two = run_sweep(plan, tmp_path / "two", client=client)
    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as single,
    ):
        one = run_sweep(plan, tmp_path / "one", client=single)
    assert (one.ok, two.ok) == (4, 4)
    rows_one = pq.read_table(tmp_path / "one" / RESULTS_FILE).to_pylist()
    rows_two = pq.read_table(tmp_path / "two" / RESULTS_FILE).to_pylist()
    assert len({r["worker"] for r in rows_one}) == 1
    assert len({r["worker"] for r in rows_two}) == 2
    strip = [{k: v for k, v in r.items() if k not in WALL_CLOCK_COLUMNS} for r in rows_one]
    assert strip == [{k: v for k, v in r.items() if k not in WALL_CLOCK_COLUMNS} for r in rows_two]
    coverage = [r["fleet.companions.coverage_fraction"] for r in rows_one]
    assert all(0 < c <= 1 for c in coverage)
    assert len(set(coverage)) > 1  # the seeds and fleet sizes make a difference


@pytest.mark.slow  # 9 s; the lost-worker retry itself is in the default run (test_cluster.py)
def test_a_trial_that_keeps_killing_its_workers_fails_with_killed_worker(tmp_path):
    """After allowed-failures + 1 worker deaths the scheduler gives up on the trial (only it)."""
    sweep = tmp_path / "grid.yaml"
    sweep.write_text(f"scenario: {DATA / 'tiny.yaml'}\ngrid:\n  fleet.0.count: [1, 2, 3]\n")
    plan = plan_sweep(sweep)
    with (
        dask.config.set({"distributed.scheduler.allowed-failures": 1}),
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as c,
    ):
        summary = run_sweep(
            plan, tmp_path / "out", client=c, execute=trial_bodies.dies_for_two_vehicles
        )
    assert (summary.ok, summary.failed) == (2, 1)
    rows = {
        r["fleet.0.count"]: r for r in pq.read_table(tmp_path / "out" / RESULTS_FILE).to_pylist()
    }
    assert rows[2]["status"] == "failed"
    assert "KilledWorker" in rows[2]["error"]
    assert "gave up on this trial after 2 worker(s) died" in rows[2]["error"]
    assert rows[2]["retries"] == 2
    assert rows[1]["status"] == rows[3]["status"] == "ok"
