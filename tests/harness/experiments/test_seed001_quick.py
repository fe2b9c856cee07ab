"""``swarmsitl experiment seed001 --quick`` end to end: a real Dask cluster, every output.

One worker (``--workers 1``; the default is 2): one busy process at a time. Marked ``slow`` (run
it with ``pytest -m slow tests/harness/experiments/test_seed001_quick.py``) while option 2's
formation keeping is reworked: today its 0.1 m threshold has the UAVs chase their formation, and
the quick design's option-2 runs take minutes (docs/seed001.md, "State").
"""

from __future__ import annotations

import math
import subprocess
import sys

import pyarrow.parquet as pq
import pytest

pytestmark = [pytest.mark.process, pytest.mark.slow]

ISSUE_COLUMNS = [
    "case", "option", "planner", "drones", "obstacles", "d_min_m", "threshold_m", "run",
    "pq_pct", "mc_pct", "ad", "ft", "fc_pct", "cf", "collisions", "plan_ms",
]  # fmt: skip


def test_the_quick_experiment_writes_its_table_tables_plots_and_result(tmp_path) -> None:
    out = tmp_path / "seed001"
    command = ["experiment", "seed001", "--quick", "--workers", "1", "--out", str(out)]
    done = subprocess.run(
        [sys.executable, "-m", "harness.cli", *command], capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith("RESULT experiment=seed001 runs=28 ok=28 "), last
    table = pq.read_table(out / "results.parquet")
    assert table.column_names[: len(ISSUE_COLUMNS)] == ISSUE_COLUMNS
    rows = table.to_pylist()
    assert len(rows) == 28 and all(r["status"] == "ok" and r["passed"] for r in rows)
    assert {r["case"] for r in rows} == {"safe_distance", "obstacles", "threshold", "fig13",
                                         "table2"}  # fmt: skip
    for r in rows:
        assert r["mc_pct"] == 100.0, r  # every UAV reached its target
        assert 0.0 < r["pq_pct"] <= 100.0 and r["ft"] > 0 and r["plan_ms"] > 0
        has_fc = r["fc_pct"] is not None and math.isfinite(r["fc_pct"])
        assert has_fc == (r["option"] == 2), r
        assert r["collisions"] >= 0 and r["ad"] >= 0
    tables = (out / "tables.md").read_text()
    for printed in ("97.7058", "26.8118", "99.74"):
        assert printed in tables
    assert "## The paper's stated trends, tested on our runs" in tables
    for name in ("safe_distance", "obstacles", "threshold", "fig13", "table2"):
        assert (out / "plots" / f"{name}.png").stat().st_size > 10_000
