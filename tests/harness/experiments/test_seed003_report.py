"""Seed 003's tables from a synthetic results table: paper beside ours, ANOVA, Tukey, RESULT."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest

from harness.experiments import seed003
from harness.experiments.seed003_report import anova, tukey, write_report


def synthetic(cfg, exec_offset: dict[str, float], rng) -> pa.Table:
    """Runs whose execution time depends on the solution (offset) and the range, nothing else."""
    rows = []
    for alg in cfg.algorithms:
        for n in cfg.scales:
            for f in cfg.ranges:
                for run in cfg.runs:
                    rows.append({
                        "algorithm": alg, "agents": n, "range_frac": f, "run": run,
                        "optimality_gap": float(rng.uniform(0.05, 0.3)),
                        "convergence_steps": float(rng.integers(10, 50)),
                        "execution_time": 8.0 + exec_offset[alg] + 4 * f + rng.normal(0, 0.5),
                        "tasks_assigned": n, "tasks_released": int(alg == "icf"),
                        "tasks_validated": n, "tasks_total": n, "tasks_completed_twice": 0,
                        "vehicles_lost": 1, "status": "ok", "passed": True, "error": "",
                    })  # fmt: skip
    return pa.Table.from_pylist(rows)


def test_tables_put_ours_beside_the_paper_and_the_anova_finds_the_solution_effect(tmp_path):
    cfg = seed003.make_config(quick=False, runs=6)
    rng = np.random.default_rng(0)
    results = synthetic(cfg, {"ica": 2.0, "gbaa": 1.0, "icf": 0.0}, rng)
    said = []
    line = write_report(results, cfg, tmp_path, said.append)
    text = (tmp_path / "tables.md").read_text()
    # the paper's numbers are there, beside ours (Table 3, ICF, 30 agents, 1D: 14.08 / 3.57)
    assert "14.08 / 3.57" in text and "0.237 / 0.171" in text and "4938.42 / 449.05" in text
    assert "## Table 6: ANOVA of execution_time" in text and "Tukey HSD" in text
    rows = results.to_pylist()
    terms = anova(rows, "execution_time")
    assert terms["S"][2] < 1e-6 and terms["CL"][2] < 1e-6  # built into the data
    assert terms["S:AT:CL"][2] > 0.001  # not built in
    assert terms["Error"][0] == len(rows) - 27
    assert anova(rows, "optimality_gap")["S"][2] > 0.001
    pairs = {(a, b): (d, rej) for a, b, d, _, rej in tukey(rows, "execution_time")}
    assert pairs[("gbaa", "ica")] == (pytest.approx(1.0, abs=0.3), True)
    assert pairs[("gbaa", "icf")][0] == pytest.approx(-1.0, abs=0.3)
    assert line.startswith("RESULT experiment=seed003 runs=162 ok=162 ")
    assert "fastest=icf" in line and "anova_S_exec_p=<0.001" in line
    assert {p.name for p in (tmp_path / "plots").iterdir()} == {
        "optimality_gap.png", "convergence_steps.png", "execution_time.png"
    }  # fmt: skip


def test_quick_tables_leave_out_what_the_runs_cannot_estimate(tmp_path):
    cfg = seed003.make_config(quick=True, runs=1)
    results = synthetic(cfg, {"ica": 0.0, "gbaa": 0.0, "icf": 0.0}, np.random.default_rng(1))
    line = write_report(results, cfg, tmp_path, print)
    text = (tmp_path / "tables.md").read_text()
    assert "| ICF | 30 |" not in text  # quick: 5x5 and 15x15 only
    assert "runs=18 " in line
    # one run per cell: no residual degrees of freedom, so no interval and no F test of the
    # full-factorial model; the table says the cell's mean without an sd
    assert "| ICA | 5 |" in text


def test_the_design_has_837_runs_with_common_random_numbers():
    cfg = seed003.make_config(quick=False)
    plan = seed003.sweep_plan(cfg, Path("seed003.py"))
    assert len(plan.trials) == 837
    quick = seed003.sweep_plan(seed003.make_config(quick=True), Path("seed003.py"))
    assert len(quick.trials) == 90
    # the three solutions of a cell run the same scenario text with the same seeds
    by_alg = {}
    for t in plan.trials:
        values = dict(t.values)
        key = (values["fleet.0.count"], values[seed003.RANGE_KEY], t.seed)
        by_alg.setdefault(key, set()).add((t.scenario_text, values[seed003.ALGORITHM_KEY]))
    assert all(len({text for text, _ in v}) == 1 and len(v) == 3 for v in by_alg.values())
    with pytest.raises(seed003.ExperimentError, match="--runs"):
        seed003.make_config(quick=True, runs=0)


def test_the_cli_offers_seed003_with_an_example(tmp_path):
    from typer.testing import CliRunner

    from harness.cli import app

    result = CliRunner().invoke(app, ["experiment", "seed999", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "seed003" in result.output
    help_text = CliRunner().invoke(app, ["experiment", "--help"]).output
    assert "seed003 --quick" in help_text and "--runs" in help_text
