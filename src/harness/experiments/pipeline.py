"""What every ``swarmsitl experiment`` does once its trials are planned.

Run the plan on the sweep machinery (Dask, one row per trial, resume), turn the sweep's rows into
the experiment's table (``results.parquet``, the issue's columns), write its tables, plots and
``config.json``, and print the ``RESULT`` line last. The seeds differ only in their plan, their
table and their report (``seed003``, ``seed004``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from harness.sweep.spec import SweepPlan


def last_error_line(row: dict[str, Any]) -> str:
    """The last line of a sweep row's error (the exception), or ``""``."""
    lines = (row.get("error") or "").strip().splitlines()
    return lines[-1] if lines else ""


def run_plan(
    plan: SweepPlan,
    out_dir: Path,
    *,
    execute: Callable[..., dict],
    tabulate: Callable[[pa.Table], pa.Table],
    report: Callable[[pa.Table, Path, Callable[[str], None]], str],
    config: dict[str, Any],
    quick: bool,
    workers: int = 2,
    scheduler: str | None = None,
    console: Any = None,
    say: Callable[[str], None] = print,
) -> int:
    """Run (or resume) ``plan`` into ``out_dir``; return 0 when every trial ran and passed.

    ``tabulate`` maps the sweep's table to the experiment's; ``report`` writes the tables and
    plots from it and returns the RESULT line; ``config`` goes to ``config.json``.
    """
    from harness.sweep.runner import run_sweep

    out_dir = Path(out_dir)
    design = "quick" if quick else "full"
    say(f"{plan.name}: {len(plan.trials)} trials ({design}); output {out_dir}")
    summary = run_sweep(
        plan, out_dir / "sweep", scheduler=scheduler, workers=workers, execute=execute,
        console=console, plots=False,
    )  # fmt: skip
    say(summary.describe())
    results = tabulate(pq.read_table(out_dir / "sweep" / "results.parquet"))
    pq.write_table(results, out_dir / "results.parquet")
    result_line = report(results, out_dir, say)
    (out_dir / "config.json").write_text(json.dumps(config, indent=2) + "\n")
    failed = summary.outcome.errored + summary.outcome.checks_failed + summary.outcome.missing
    say(result_line)
    return 0 if failed == 0 else 1
