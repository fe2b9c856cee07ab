"""Seed 001's experiment design, results table and report, without running the swarm."""

from __future__ import annotations

import math
from pathlib import Path

import pyarrow as pa
import pytest

from harness.experiments import seed001
from harness.experiments.seed001_report import (
    PAPER_TABLE2,
    trend,
    verdict,
    write_report,
)
from harness.scenarios.spec import parse_scenario
from harness.sweep.trial import build_scenario

SOURCE = Path(seed001.__file__)


def test_the_full_design_has_table_2_with_35_runs_and_sweeps_with_10() -> None:
    cfg = seed001.make_config(False)
    cases = cfg.cases()
    assert [(c.obstacles, c.drones) for c in cases if c.case == "table2"] == list(seed001.TABLE2)
    assert all(c.option == 2 and c.threshold_m == 0.1 and c.d_min_m == 1.0
               for c in cases if c.case in ("table2", "fig13"))  # fmt: skip
    assert {c.d_min_m for c in cases if c.case == "safe_distance"} == {1.0, 2.0, 3.0}
    assert all(c.obstacles == 0 and c.option == 1 for c in cases if c.case == "safe_distance")
    assert {c.planner for c in cases if c.option == 1} == {"aco", "astar"}
    plan = seed001.sweep_plan(cfg, SOURCE)
    per_case = {}
    for c, t in seed001._trials(cfg, SOURCE):
        per_case.setdefault(c, []).append(t.seed)
    assert all(len(v) == (35 if c.case == "table2" else 10) for c, v in per_case.items())
    ids = [t.trial_id for t in plan.trials]
    assert len(ids) == len(set(ids)) == 9 * 35 + (24 + 32 + 16 + 5) * 10


def test_runs_and_quick() -> None:
    quick = seed001.make_config(True)
    assert len(seed001.sweep_plan(quick, SOURCE).trials) == 28
    assert seed001.make_config(False, 3).sweep_runs == (0, 1, 2)
    with pytest.raises(seed001.ExperimentError, match="--runs"):
        seed001.make_config(True, 0)


@pytest.mark.parametrize("row", [(6, 5), (85, 80)])
def test_every_case_builds_a_valid_scenario_even_80_uavs_with_3_m_gaps(row, tmp_path) -> None:
    """The largest fleet fits the start zone; the run seed reseeds the world (new drums)."""
    k, n = row
    case = seed001.Case("table2", 2, "aco", n, k, 3.0, 0.1)
    text = seed001.scenario_text(case)
    scenario = parse_scenario(text, "seed001.yaml", tmp_path)
    assert scenario.spec.n_vehicles == n
    movers = [s for s in scenario.world.solids if s.motion is not None]
    assert len(movers) == k
    trials = [t for c, t in seed001._trials(seed001.make_config(True), SOURCE)]
    a = build_scenario(trials[0])
    b = build_scenario(next(t for t in trials if t.seed != trials[0].seed
                            and t.scenario_text == trials[0].scenario_text))  # fmt: skip
    assert a.world.launch_areas == b.world.launch_areas


def _rows(cfg: seed001.Seed001Config) -> list[dict]:
    """Synthetic results: PQ falling with D_min, FT with the threshold, AD rising with drums."""
    out = []
    for c, t in seed001._trials(cfg, SOURCE):
        out.append({
            "trial_id": t.trial_id, "seed": t.seed, "status": "ok", "passed": True,
            "fleet.run.pq": 100.0 - 3.0 * c.d_min_m - 0.01 * c.obstacles - 0.1 * t.seed,
            "fleet.run.mc": 100.0, "fleet.run.ad": 1.0 + 0.1 * c.obstacles + 0.01 * t.seed,
            "fleet.run.ft": 1.0 + 0.01 * c.obstacles - 0.2 * c.threshold_m + 0.001 * t.seed,
            "fleet.run.fc": None if c.option == 1 else 30.0 - 10 * c.threshold_m + 0.1 * t.seed,
            "fleet.run.cf": 34.0 - 0.01 * c.obstacles - 0.01 * t.seed,
            "fleet.collisions": 0, "fleet.run.plan_ms_mean": 2.0 + 0.1 * t.seed,
        })  # fmt: skip
    return out


def test_results_table_and_report_on_known_trends(tmp_path) -> None:
    cfg = seed001.Seed001Config(
        False, (0, 1, 2), (0, 1, 2), sweep_drones=(5, 10), fig13_obstacles=(10, 50, 100)
    )
    sweep = pa.Table.from_pylist([*_rows(cfg), {"trial_id": "stale", "seed": 0, "status": "ok"}])
    table = seed001.results_table(sweep, cfg, SOURCE)
    issue = ["case", "option", "planner", "drones", "obstacles", "d_min_m", "threshold_m", "run",
             "pq_pct", "mc_pct", "ad", "ft", "fc_pct", "cf", "collisions", "plan_ms"]  # fmt: skip
    assert table.column_names[: len(issue)] == issue
    rows = table.to_pylist()
    assert len(rows) == len(seed001.sweep_plan(cfg, SOURCE).trials)  # the stale row dropped
    assert all(math.isnan(r["threshold_m"]) for r in rows if r["option"] == 1)
    rho, p, _n = trend(rows, "safe_distance", "pq_pct", "d_min_m")
    assert rho < 0 and p < 0.05 and verdict(rho, p, -1) == "reproduced"
    assert verdict(rho, p, +1) == "opposite" and verdict(0.1, 0.4, -1) == "flat"
    result = write_report(table, cfg, tmp_path, print)
    assert result.startswith("RESULT experiment=seed001 runs=")
    assert "trends_reproduced=" in result and "collisions=0" in result
    text = (tmp_path / "tables.md").read_text()
    for printed in ("97.7058", "26.8118", "34.3594", "2.5419"):
        assert printed in text
    assert "| safe_distance | PQ falls as D_min grows (Fig. 3) |" in text
    assert "reproduced" in text
    assert len(PAPER_TABLE2) == 9
    for name in ("safe_distance", "obstacles", "threshold", "fig13", "table2"):
        assert (tmp_path / "plots" / f"{name}.png").stat().st_size > 10_000
