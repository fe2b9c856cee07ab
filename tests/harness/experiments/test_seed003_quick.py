"""``swarmsitl experiment seed003 --quick`` end to end: a real Dask cluster, every output.

The cluster has one worker here (``--workers 1``; the default is 2): one busy process at a time,
so this module is in the process tier and runs beside the e2e group instead of after it
(tests/conftest.py, Scheduling). The results do not depend on the number of workers.
"""

from __future__ import annotations

import subprocess
import sys
from collections import defaultdict

import pyarrow.parquet as pq
import pytest

pytestmark = pytest.mark.process

ISSUE_COLUMNS = [
    "algorithm", "agents", "range_frac", "run", "optimality_gap", "convergence_steps",
    "execution_time", "tasks_assigned", "tasks_released", "tasks_validated",
]  # fmt: skip


def test_the_quick_experiment_writes_its_table_tables_plots_and_result(tmp_path) -> None:
    out = tmp_path / "seed003"
    command = ["experiment", "seed003", "--quick", "--workers", "1", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "harness.cli", *command], capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("RESULT experiment=seed003 runs=90 ok=90 "), last
    table = pq.read_table(out / "results.parquet")
    assert set(ISSUE_COLUMNS) <= set(table.column_names)
    rows = table.to_pylist()
    assert len(rows) == 90 and all(r["status"] == "ok" and r["passed"] for r in rows)
    assert {(r["algorithm"], r["agents"], r["range_frac"]) for r in rows} == {
        (a, n, f) for a in ("ica", "gbaa", "icf") for n in (5, 15) for f in (0.1, 0.5, 1.0)
    }
    for r in rows:
        assert r["tasks_validated"] == r["tasks_total"] == r["agents"], r  # every task done
        assert -0.5 < r["optimality_gap"] < 1.0 and r["execution_time"] > 0
        assert r["convergence_steps"] > 0 and r["tasks_assigned"] >= r["agents"] - 2
    # common random numbers: the three solutions of a cell lose the same vehicles
    lost = defaultdict(set)
    for r in rows:
        lost[(r["agents"], r["range_frac"], r["run"])].add(r["vehicles_lost"])
    assert all(len(v) == 1 for v in lost.values())
    assert sum(r["vehicles_lost"] for r in rows) > 0
    # ICF releases orphaned tasks (Eqs. 22-25) in runs that lost a vehicle; the baselines have
    # no release mechanism to count
    icf_lost = [r for r in rows if r["algorithm"] == "icf" and r["vehicles_lost"]]
    assert any(r["tasks_released"] > 0 for r in icf_lost)
    assert all(r["tasks_released"] == 0 for r in rows if r["algorithm"] != "icf")
    tables = (out / "tables.md").read_text()
    for paper_number in ("0.237 / 0.171", "16.81 / 3.65", "6.29 / 2.19", "0.152"):
        assert paper_number in tables
    assert "Tukey HSD" in tables and "## Table 5: ANOVA of convergence_steps" in tables
    for name in ("optimality_gap", "convergence_steps", "execution_time"):
        assert (out / "plots" / f"{name}.png").stat().st_size > 10_000
