"""``swarmsitl experiment seed004 --quick`` end to end: a real Dask cluster, every output.

The cluster has one worker here (``--workers 1``; the default is 2): one busy process at a time,
so this module is in the process tier and runs beside the e2e group instead of after it
(tests/conftest.py, Scheduling). The results do not depend on the number of workers.
"""

from __future__ import annotations

import subprocess
import sys

import pyarrow.parquet as pq
import pytest

from harness.experiments.seed004 import COLUMNS, make_config

pytestmark = pytest.mark.process

ISSUE_COLUMNS = [
    "workspace", "planner", "n", "seed", "heterogeneity_std_pct", "mean_remaining_battery_pct",
    "min_remaining_battery_pct", "mission_time_s", "links_per_agent_mean", "waypoints",
]  # fmt: skip


def test_the_quick_experiment_writes_its_table_tables_plots_and_result(tmp_path) -> None:
    out = tmp_path / "seed004"
    command = ["experiment", "seed004", "--quick", "--workers", "1", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "harness.cli", *command], capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("RESULT trials=48 ok=48 "), last
    cfg = make_config(quick=True)
    table = pq.read_table(out / "results.parquet")
    assert table.num_rows == sum(len(ns) for ns in cfg.n_values.values()) * 4 * len(cfg.seeds)
    assert set(ISSUE_COLUMNS + list(COLUMNS.values())) <= set(table.column_names)
    rows = table.to_pylist()
    assert all(r["status"] == "ok" and r["passed"] for r in rows)
    for r in rows:
        assert 0.0 <= r["min_remaining_battery_pct"] <= r["mean_remaining_battery_pct"] <= 100.0
        assert r["mission_time_s"] > 0 and r["links_per_agent_mean"] >= 0
        batteries = [r[f"battery_agent_{k}"] for k in range(1, r["n"] + 1)]
        assert min(batteries) == pytest.approx(r["min_remaining_battery_pct"])
    waypoints = {(r["workspace"]): r["waypoints"] for r in rows}
    assert waypoints["rejoya"] > waypoints["urban"] > waypoints["naranjos"]  # 70 > 54 > 27 ha
    tables = (out / "tables.md").read_text()
    for paper_number in ("89.93", "130.2", "279", "9.2", "10.0"):
        assert paper_number in tables
    for name in ("partitions", "battery_per_agent", "links_over_time", "by_fleet_size"):
        assert (out / "plots" / f"{name}.png").stat().st_size > 10_000
    assert not (out / "sweep" / "plots").exists(), "the experiment draws its own plots"
