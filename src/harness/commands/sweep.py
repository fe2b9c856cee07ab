"""``swarmsitl sweep SWEEP.yaml``: scenario parameters x seeds on Dask (docs/sweeps.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.markup import escape

from harness.run.launch import console
from harness.sweep.spec import SweepError, SweepPlan, plan_sweep

if TYPE_CHECKING:
    from harness.sweep.runner import SweepOutcome

EXIT_OK = 0
"""Every trial that ran passed its scenario's checks."""
EXIT_ERRORED = 1
"""At least one trial errored (raised, or its workers kept dying; its row holds the traceback).
Running the command again reruns those trials."""
EXIT_BAD_INPUT = 2
"""The sweep file (or its scenario, or a grid value) is wrong, or the scheduler is unreachable:
nothing was submitted."""
EXIT_CHECKS_FAILED = 3
"""No trial errored but at least one failed its scenario's checks (``passed`` false). Running
the command again does not rerun them: their result is what the scenario, values and seed give."""
EXIT_INTERRUPTED = 130
"""Ctrl-C: the rows of the trials that finished are kept (the next run resumes)."""
SHOWN_FAILURES = 5
"""Failing trials listed by name at the end of a sweep (the table has them all)."""


def exit_status(outcome: SweepOutcome) -> int:
    """The exit status of a sweep that ran to its end: errors first, then failed checks.

    Trials not run (``--max-trials``) do not count: a partial sweep that passed so far exits 0.
    """
    if outcome.errored:
        return EXIT_ERRORED
    if outcome.checks_failed:
        return EXIT_CHECKS_FAILED
    return EXIT_OK


def failure_line(row: dict[str, Any], parameters: list[str]) -> str:
    """One failing trial: its id, grid point, seed, and the checks it failed or its error."""
    head = (
        f"{row['trial_id']}  {json.dumps({k: row.get(k) for k in parameters})}  seed {row['seed']}"
    )
    if row.get("status") != "ok":
        lines = (row.get("error") or "").strip().splitlines()
        return f"{head}  errored: {lines[-1] if lines else '?'}"
    if row.get("failed_checks"):
        return f"{head}  failed checks: {row['failed_checks']}"
    if not row.get("complete"):
        return f"{head}  failed: the run did not complete"
    return f"{head}  failed its checks"


def print_trials(plan: SweepPlan, out_dir: Path) -> None:
    """``--dry-run``: every trial, its id, parameters and seed, and whether it already ran ok."""
    from harness.sweep.runner import pending_trials

    pending, _ = pending_trials(plan, out_dir)
    todo = {t.trial_id for t in pending}
    for t in plan.trials:
        state = "to run" if t.trial_id in todo else "done (ok)"
        console.print(
            f"{t.trial_id}  {json.dumps(t.parameters)}  seed {t.seed}  {state}",
            markup=False,
            highlight=False,
        )
    console.print(f"{len(plan.trials)} trial(s), {len(pending)} to run; output {out_dir}")


def sweep(
    file: Annotated[
        Path, typer.Argument(exists=True, dir_okay=False, help="the sweep file (YAML)")
    ],
    out: Annotated[
        Path | None,
        typer.Option(help="output directory (default: runs/sweep-NAME); reused to resume"),
    ] = None,
    workers: Annotated[
        int,
        typer.Option(
            min=1,
            help="worker processes of the local Dask cluster (one trial each at a time); keep it "
            "low for fidelity: full scenarios (e.g. --workers 2)",
        ),
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option(
            metavar="ADDRESS",
            help="run on the Dask scheduler at ADDRESS instead of a local cluster (e.g. "
            "--scheduler tcp://10.0.0.5:8786, started with `dask scheduler`)",
        ),
    ] = None,
    max_trials: Annotated[
        int | None,
        typer.Option(min=1, help="run at most N of the trials still to run (e.g. --max-trials 4)"),
    ] = None,
    dry_run: Annotated[
        bool,
        typer.Option("--dry-run", help="check the sweep file, list its trials, run nothing"),
    ] = False,
) -> None:
    """Run a parameter sweep: every grid point x every seed, one scenario run per trial, on Dask.

    Checks the sweep file and the scenario of every grid point before anything is submitted,
    then runs the trials on a local Dask cluster (--workers) or an existing scheduler
    (--scheduler), skipping those that already finished ok in the output directory. Writes
    OUT/results.parquet (a row per trial: parameters, seed, status, traceback, retries, metrics),
    OUT/trials/ (a row per finished trial, written as it finishes) and OUT/plots/METRIC.png
    (mean over seeds; its 95 % confidence band where a point has 3 or more seeds). Ends with
    the counts of trials that passed, failed the scenario's checks, errored, or are not run yet.

    Exit status: 0 when every trial that ran passed its checks; 1 when a trial errored (raised or
    lost its workers; rerun the command to retry them); 2 for a bad sweep file or an unreachable
    scheduler (nothing ran); 3 when no trial errored but one failed its checks (passed = false
    in the table); 130 after Ctrl-C.

    Example:  swarmsitl sweep examples/sweeps/coverage_1_to_1000.yaml --workers 2

    Example:  swarmsitl sweep examples/sweeps/coverage_1_to_1000.yaml --dry-run
    """
    try:
        plan = plan_sweep(file)
    except SweepError as exc:
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    out_dir = (out or Path("runs") / f"sweep-{plan.name}").absolute()
    if dry_run:
        print_trials(plan, out_dir)
        return
    from harness.sweep.runner import run_sweep

    where = scheduler or f"a local cluster of {workers} worker process(es)"
    console.print(
        f"[bold]sweep {escape(plan.name)}[/bold]: {len(plan.trials)} trial(s) "
        f"({len(plan.trials) // len(plan.spec.seed_list)} grid point(s) x "
        f"{len(plan.spec.seed_list)} seed(s)) of {escape(str(plan.scenario_path))} "
        f"(fidelity {plan.fidelity}) on {escape(where)}; output {escape(str(out_dir))}"
    )
    try:
        summary = run_sweep(
            plan, out_dir, scheduler=scheduler, workers=workers, max_trials=max_trials,
            console=console,
        )  # fmt: skip
    except OSError as exc:  # e.g. no scheduler at --scheduler
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    except KeyboardInterrupt:
        console.print(
            f"interrupted: the finished trials' rows are in {out_dir / 'results.parquet'}; run "
            "the same command again to resume"
        )
        raise typer.Exit(EXIT_INTERRUPTED) from None
    for warning in summary.warnings:
        console.print(f"[yellow]warning:[/yellow] {escape(warning)}")
    if summary.table is not None:
        console.print(f"table: {summary.table}", markup=False, highlight=False)
    if summary.plots:
        console.print(f"plots: {summary.plots[0].parent}/ ({len(summary.plots)} PNG)", markup=False)
    parameters = plan.parameters
    for row in summary.failing[:SHOWN_FAILURES]:
        console.print(failure_line(row, parameters), markup=False, highlight=False)
    if len(summary.failing) > SHOWN_FAILURES:
        console.print(f"... and {len(summary.failing) - SHOWN_FAILURES} more in the table")
    console.print(summary.describe(), markup=False, highlight=False)
    outcome = summary.outcome
    if outcome.checks_failed:
        console.print(
            f"[yellow]{outcome.checks_failed} trial(s) failed their checks[/yellow]: passed = "
            "false in the table, the checks in its failed_checks column"
        )
    if outcome.errored:
        console.print(
            f"[red]{outcome.errored} trial(s) errored[/red]: their tracebacks are in the error "
            "column; run the same command again to rerun only them"
        )
    status = exit_status(outcome)
    if status != EXIT_OK:
        raise typer.Exit(status)
