"""One trial of a sweep: (scenario, dotted parameter values, seed) -> one table row.

``run_trial`` runs on a Dask worker (or in-process). It builds the trial's scenario from the
scenario text with the parameters applied and the seed set, runs it at the scenario's fidelity
(``swarm``: ``harness.swarm.run.run_swarm`` in-process; ``full``: a lockstep ``ScenarioRun``
with free ports in the trial's run directory), and flattens the report into numeric columns
named as ``checks.metrics`` names them (``fleet.min_separation``,
``fleet.companions.spills_seen``). Every exception becomes a failed row with its traceback: one
broken trial never stops a sweep. A trial's row depends only on (scenario, parameters, seed).
"""

from __future__ import annotations

import dataclasses
import json
import math
import socket
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from harness.scenarios.spec import Scenario, parse_scenario
from harness.sweep.params import apply_parameters

Execute = Callable[[Scenario, int, "Path | None", "float | None"], dict[str, Any]]
"""Runs a built scenario with a seed (run directory or None, wall timeout or None) -> report."""

ERROR_CHARS = 20_000
"""Longest traceback kept in a failed row."""
UNITS_KEY = "__units__"
"""Row entry (not a column) with the unit of each metric column; the table keeps it as the
column's Parquet field metadata ``unit``."""


@dataclass(frozen=True)
class Trial:
    """What one trial runs; its id is a hash of everything that determines its result."""

    trial_id: str
    scenario_source: str
    """The scenario file (relative paths in it start at its folder)."""
    scenario_text: str
    values: tuple[tuple[str, Any], ...]
    """(dotted parameter, value) pairs of the trial's grid point, in grid order."""
    seed: int
    timeout_wall_s: float | None = None
    """Full fidelity: give up the run after this many wall seconds."""
    run_dir: str | None = None
    """Where a full-fidelity run writes its run directory (None: a temporary one); the sweep
    sets OUT/runs/TRIAL_ID."""

    @property
    def parameters(self) -> dict[str, Any]:
        """The grid point as a mapping."""
        return dict(self.values)


def build_scenario(trial: Trial) -> Scenario:
    """The trial's scenario: the text with its parameters applied and its seed, validated."""
    data = yaml.safe_load(trial.scenario_text)
    data = apply_parameters(data, trial.parameters)
    data["seed"] = trial.seed
    text = yaml.safe_dump(data, sort_keys=False)
    source = Path(trial.scenario_source)
    label = f"{source} [{json.dumps(trial.parameters)}, seed {trial.seed}]"
    scenario = parse_scenario(text, label, source.parent)
    return dataclasses.replace(scenario, path=source)


def execute_scenario(
    scenario: Scenario, seed: int, run_dir: Path | None, timeout_wall_s: float | None
) -> dict[str, Any]:
    """Run ``scenario`` at its fidelity and return its report (the default trial body).

    A swarm-fidelity run writes no run directory (thousands of trials, one row each); a full one
    writes ``run_dir`` (a temporary directory when None), as ``swarmsitl run`` does.
    """
    if scenario.spec.fidelity == "swarm":
        from harness.swarm.run import run_swarm

        return run_swarm(scenario, seed, None)
    from harness.run.ports import free_ports
    from harness.scenarios.runner import RunOptions, ScenarioRun

    if run_dir is None:
        with tempfile.TemporaryDirectory(prefix="swarmsitl-trial-") as tmp:
            return execute_scenario(scenario, seed, Path(tmp), timeout_wall_s)
    ports = free_ports(scenario.spec.n_vehicles)
    options = RunOptions(run_dir, seed, None, ports, timeout_wall_s)
    return ScenarioRun(scenario, options).run()


def _number(value: Any) -> float | None:
    """A report value as a float column entry; None for what is not a finite-or-nan number."""
    if isinstance(value, bool):
        return float(value)
    if isinstance(value, int | float):
        return float(value)
    return None


def metric_units(report: dict[str, Any]) -> dict[str, str]:
    """The unit of every ``flatten_metrics`` column whose report entry gives one."""
    out: dict[str, str] = {}

    def walk(node: Any, prefix: str) -> None:
        if not isinstance(node, dict):
            return
        if "value" in node:
            value = node["value"]
            if (value is None or _number(value) is not None) and node.get("unit"):
                out[prefix] = str(node["unit"])
            return
        for key, child in node.items():
            walk(child, f"{prefix}.{key}")

    walk(report.get("fleet", {}), "fleet")
    return out


def flatten_metrics(report: dict[str, Any]) -> dict[str, float | None]:
    """Every numeric ``fleet`` metric of a report as ``{"fleet.NAME": value}``.

    A ``{"value": v, ...}`` entry gives ``v`` under its dotted path, the name
    ``harness.report.totals.lookup`` (and so ``checks.metrics``) resolves; ``{"value": None}``
    (a metric the run could not compute, or a non-finite one) gives None, a null cell, so that
    its column exists; plain numbers count too; lists and texts are left out. Booleans become
    0/1 so that their mean is a share.
    """
    out: dict[str, float | None] = {}

    def walk(node: Any, prefix: str) -> None:
        if isinstance(node, dict):
            if "value" in node:
                number = _number(node["value"])
                if number is not None or node["value"] is None:
                    out[prefix] = number
                return
            for key, child in node.items():
                walk(child, f"{prefix}.{key}")
            return
        number = _number(node)
        if number is not None:
            out[prefix] = number

    walk(report.get("fleet", {}), "fleet")
    return out


def failed_checks(report: dict[str, Any]) -> list[str]:
    """Names of the report's checks that did not pass, in report order.

    Kept in the row because a swarm-fidelity trial writes no report.json: without it the table
    would say that a trial failed its checks but not which.
    """
    checks = report.get("checks") or {}
    return [
        str(name)
        for name, check in checks.items()
        if isinstance(check, dict) and not check.get("ok", True)
    ]


def _worker_name() -> str:
    """The Dask worker running this (its address), or the host's name outside a worker."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return socket.gethostname()


def base_row(trial: Trial) -> dict[str, Any]:
    """The columns every row has, before the trial ran."""
    return {
        "trial_id": trial.trial_id,
        **trial.parameters,
        "seed": trial.seed,
        "status": "failed",
        "error": "",
        "retries": 0,
        "worker": _worker_name(),
        "wall_s": math.nan,
        "sim_time_s": math.nan,
        "passed": False,
        "complete": False,
        "failed_checks": "",
    }


def run_trial(trial: Trial, execute: Execute | None = None) -> dict[str, Any]:
    """Run one trial; its row (``status`` ok or failed with the traceback in ``error``).

    ``execute`` replaces the scenario run (a test hook: the sweep machinery with a trial body
    of the test's choosing); it must be importable or picklable by the Dask workers.
    """
    row = base_row(trial)
    start = time.perf_counter()
    try:
        scenario = build_scenario(trial)
        run_dir = Path(trial.run_dir) if trial.run_dir is not None else None
        report = (execute or execute_scenario)(scenario, trial.seed, run_dir, trial.timeout_wall_s)
        if "fleet" not in report:  # e.g. a full-fidelity run whose simulation did not start
            raise RuntimeError(f"the run wrote no metrics: {report.get('error', report)}")
        row["sim_time_s"] = float(report.get("sim_time_s", math.nan))
        row["passed"] = bool(report.get("passed", False))
        row["complete"] = bool(report.get("complete", False))
        row["failed_checks"] = ", ".join(failed_checks(report))
        row |= flatten_metrics(report)
        row[UNITS_KEY] = metric_units(report)
        row["status"] = "ok"
    except Exception:  # every failure of a trial is data, the sweep goes on
        row["error"] = traceback.format_exc()[-ERROR_CHARS:]
    row["wall_s"] = time.perf_counter() - start
    return row
