"""Schedule a sweep's trials on Dask distributed and collect their rows.

``run_sweep`` connects to a scheduler (``--scheduler tcp://HOST:8786``, or a ``Client`` a
program built, e.g. on dask-jobqueue's SLURMCluster) or starts a LocalCluster of single-threaded
worker processes, skips the trials whose row says ``ok`` (resume), submits the rest with
``pure=False`` under a key made of the trial id, and writes each row as its future completes.
A worker that dies while running a trial (killed, out of memory, node lost) makes the scheduler
run the trial elsewhere; the scheduler counts those deaths per task (``TaskState.suspicious``),
which the row keeps as ``retries``. After ``distributed.scheduler.allowed-failures`` deaths
(3 by default) the scheduler gives up on the trial, which is then recorded as failed
(``KilledWorker``). Nothing here depends on which worker ran what: a trial's row is a function
of its scenario, parameters and seed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import dask
from distributed import Client, KilledWorker, LocalCluster, as_completed
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from harness.sweep.plots import plot_sweep
from harness.sweep.spec import SweepPlan
from harness.sweep.table import RESULTS_FILE, combine, read_row, value_type, write_row
from harness.sweep.trial import Execute, Trial, base_row, run_trial

KEY_PREFIX = "swarmsitl-trial-"
"""Dask key of a trial: this + its trial id (the dashboard shows them by this prefix)."""


@dataclass
class SweepOutcome:
    """Where every trial of the sweep stands, from its rows in the output directory.

    Counted over all the sweep's trials, not only those this run ran: a resumed sweep whose
    earlier trials failed their checks still reports (and exits with) the failure.
    """

    passed: int = 0
    """Trials that ran and passed the scenario's checks (``status`` ok, ``passed``)."""
    checks_failed: int = 0
    """Trials that ran but failed a check or did not complete (``status`` ok, not ``passed``)."""
    errored: int = 0
    """Trials that raised or whose workers kept dying (``status`` failed): no metrics."""
    missing: int = 0
    """Trials without a row yet (``max_trials``, an interruption)."""

    @classmethod
    def of_rows(cls, rows: list[dict[str, Any]], trials: int) -> SweepOutcome:
        """Count the rows of the sweep's ``trials`` trials (one row per trial at most)."""
        out = cls(missing=trials - len(rows))
        for row in rows:
            if row.get("status") != "ok":
                out.errored += 1
            elif row.get("passed"):
                out.passed += 1
            else:
                out.checks_failed += 1
        return out

    def describe(self) -> str:
        """One line: passed, failed checks, errored, not run yet."""
        return (
            f"results: {self.passed} passed, {self.checks_failed} failed checks, "
            f"{self.errored} errored, {self.missing} not run"
        )


@dataclass
class SweepSummary:
    """What a sweep did (printed at the end, returned to programs)."""

    trials: int
    """Trials in the sweep."""
    ok: int = 0
    """Trials this run ran that finished (``status`` ok; their checks may have failed)."""
    failed: int = 0
    """Trials this run ran that errored (``status`` failed)."""
    skipped: int = 0
    """Trials already ``ok`` in the output directory (resume)."""
    retried: int = 0
    """Trials that a dying worker interrupted at least once."""
    retries: int = 0
    """Worker deaths while running a trial, over all trials."""
    not_run: int = 0
    """Trials left out by ``max_trials`` or an interruption."""
    wall_s: float = 0.0
    outcome: SweepOutcome = field(default_factory=SweepOutcome)
    """Every trial of the sweep (this run's and earlier runs'): passed, failed checks, errored."""
    failing: list[dict[str, Any]] = field(default_factory=list)
    """Rows of the trials that failed their checks or errored, in grid order."""
    table: Path | None = None
    plots: list[Path] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def describe(self) -> str:
        """Two lines: the sweep's outcome; this run's trials, retries, wall time and rate."""
        return (
            f"{self.outcome.describe()} (of {self.trials} trials)\n"
            f"this run: {self.ok} finished, {self.failed} errored, {self.skipped} skipped "
            f"(done before), {self.not_run} not run; {self.retried} retried after a lost worker "
            f"({self.retries} retries); {self.wall_s:.1f} s wall, "
            f"{self.trials_per_min:.1f} trials/min"
        )

    @property
    def trials_per_min(self) -> float:
        """Trials run (ok or failed) per wall minute."""
        done = self.ok + self.failed
        return 60.0 * done / self.wall_s if self.wall_s > 0 else 0.0


def _suspicious(key: str, dask_scheduler: Any = None) -> int:
    """On the scheduler: how many workers died while running task ``key``."""
    ts = dask_scheduler.tasks.get(key)
    return int(ts.suspicious) if ts is not None else 0


TRIAL_WORKER_CONFIG: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    # without Dask's MALLOC_TRIM_THRESHOLD_: any value turns off glibc's dynamic mmap threshold,
    # and the trials' numpy arrays are then mapped and unmapped at every allocation (16 % slower)
    "distributed.nanny.pre-spawn-environ": {
        "OMP_NUM_THREADS": 1,
        "MKL_NUM_THREADS": 1,
        "OPENBLAS_NUM_THREADS": 1,
    },
}
"""Dask settings of the LocalCluster's workers. A trial is a long pure-Python task: Dask's
statistical profiler (a stack sample of the task every 10 ms), its event-loop tick (20 ms) and
its system monitor (0.5 s) each take the GIL from it. Measured on 2 cores (6 trials of 30
kinematic vehicles on 2 workers): 18.0 s with Dask's defaults, 14.8 s without the profiler and
with the slower tick and monitor. Workers of your own cluster take these from their environment
(docs/sweeps.md)."""


def worker_environment() -> dict[str, str]:
    """``TRIAL_WORKER_CONFIG`` as the environment variables a Dask worker reads at start-up.

    For workers started by hand or by a job system (``export NAME=VALUE`` in a SLURM job's
    prologue); ``DASK_DISTRIBUTED__NANNY__PRE_SPAWN_ENVIRON`` is a Python literal.
    """
    env = {}
    for key, value in TRIAL_WORKER_CONFIG.items():
        name = "DASK_" + "__".join(part.replace("-", "_").upper() for part in key.split("."))
        env[name] = repr(value) if isinstance(value, dict) else str(value)
    return env


@contextlib.contextmanager
def open_client(scheduler: str | None, workers: int) -> Iterator[Client]:
    """A client of the scheduler at ``scheduler``, or of a LocalCluster of ``workers`` processes."""
    if scheduler is not None:
        client = Client(scheduler, timeout="30s")
        try:
            yield client
        finally:
            client.close()
        return
    with dask.config.set(TRIAL_WORKER_CONFIG):  # the nannies hand it to their workers
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0"
        )
    try:
        client = Client(cluster)
        try:
            yield client
        finally:
            client.close()
    finally:
        cluster.close()


def pending_trials(plan: SweepPlan, out_dir: Path) -> tuple[list[Trial], int]:
    """The trials still to run (no row, or a failed one) and how many finished ok before."""
    pending, skipped = [], 0
    for trial in plan.trials:
        row = read_row(out_dir, trial.trial_id)
        if row is not None and row.get("status") == "ok":
            skipped += 1
        else:
            pending.append(trial)
    return pending, skipped


def _lost_row(trial: Trial, exc: BaseException, retries: int) -> dict[str, Any]:
    """The row of a trial whose task, not its body, failed (KilledWorker, unpicklable, lost)."""
    row = base_row(trial)
    row["worker"] = ""
    row["retries"] = retries
    text = "".join(traceback.format_exception(exc)).rstrip()
    if isinstance(exc, KilledWorker):
        text += (
            f"\n(the scheduler gave up on this trial after {retries} worker(s) died while "
            "running it)"
        )
    row["error"] = text
    return row


def run_sweep(
    plan: SweepPlan,
    out_dir: Path,
    *,
    client: Client | None = None,
    scheduler: str | None = None,
    workers: int = 2,
    max_trials: int | None = None,
    execute: Execute | None = None,
    console: Console | None = None,
    on_row: Callable[[dict[str, Any]], None] | None = None,
    plots: bool = True,
) -> SweepSummary:
    """Run the plan's pending trials on Dask; rows in ``out_dir``, then the table and the plots.

    Args:
        plan: the checked sweep (``harness.sweep.spec.plan_sweep``).
        out_dir: output directory: trials/, results.parquet, plots/, runs/ (full fidelity).
        client: a connected Dask client to use (left open).
        scheduler: without ``client``: the address of a running scheduler (tcp://HOST:8786).
        workers: without ``client`` and ``scheduler``: worker processes of the LocalCluster.
        max_trials: run at most this many of the pending trials.
        execute: replaces the scenario run in every trial (a test hook; see ``run_trial``).
        console: where the progress bar goes (None: a quiet run).
        on_row: called with each row as it is written.
        plots: draw the sweep's plots (an experiment draws its own).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    start = time.monotonic()
    pending, skipped = pending_trials(plan, out_dir)
    summary = SweepSummary(trials=len(plan.trials), skipped=skipped)
    if max_trials is not None:
        summary.not_run = max(0, len(pending) - max_trials)
        pending = pending[:max_trials]
    runs = (out_dir / "runs").resolve()  # full-fidelity trials' run directories
    pending = [dataclasses.replace(t, run_dir=str(runs / t.trial_id)) for t in pending]
    kinds = {name: value_type(values) for name, values in plan.spec.parameter_values.items()}
    try:
        if pending:
            with contextlib.ExitStack() as stack:
                if client is None:
                    client = stack.enter_context(open_client(scheduler, workers))
                if console is not None and client.dashboard_link:
                    console.print(f"Dask dashboard: {client.dashboard_link}", highlight=False)
                _run(client, pending, out_dir, kinds, execute, console, summary, on_row)
    finally:  # Ctrl-C too: the table holds every row finished so far
        summary.wall_s = time.monotonic() - start
        table = combine(out_dir, (t.trial_id for t in plan.trials))
        summary.table = out_dir / RESULTS_FILE if table is not None else None
    rows = table.to_pylist() if table is not None else []
    summary.outcome = SweepOutcome.of_rows(rows, len(plan.trials))
    summary.failing = [r for r in rows if r.get("status") != "ok" or not r.get("passed")]
    if table is not None and plots:
        summary.plots, summary.warnings = plot_sweep(
            table, plan.spec.axes, plan.spec.x_parameter, plan.spec.metrics, out_dir / "plots",
            plan.parameters,
        )  # fmt: skip
    return summary


def _run(
    client: Client,
    pending: list[Trial],
    out_dir: Path,
    kinds: dict[str, Any],
    execute: Execute | None,
    console: Console | None,
    summary: SweepSummary,
    on_row: Callable[[dict[str, Any]], None] | None,
) -> None:
    """Submit ``pending``, write each row as it finishes, count into ``summary``."""
    by_key = {f"{KEY_PREFIX}{t.trial_id}": t for t in pending}
    futures = [
        client.submit(run_trial, trial, execute, key=key, pure=False)
        for key, trial in by_key.items()
    ]
    progress = Progress(
        TextColumn("[bold]trials[/bold]"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[status]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        disable=console is None,
        transient=False,
    )
    done = checks_failed = 0
    try:
        with progress:
            task = progress.add_task("trials", total=len(futures), status="")
            for future in as_completed(futures):
                trial = by_key[future.key]
                retries = client.run_on_scheduler(_suspicious, future.key)
                if future.status == "finished":
                    row = future.result()
                else:  # KilledWorker, a task that could not run, or one cancelled
                    exc = (
                        future.exception()
                        if future.status == "error"
                        else RuntimeError(f"the trial's task was {future.status}")
                    )
                    row = _lost_row(trial, exc, retries)
                row["retries"] = retries
                future.release()
                write_row(out_dir, kinds, row)
                done += 1
                summary.ok += row["status"] == "ok"
                summary.failed += row["status"] != "ok"
                checks_failed += row["status"] == "ok" and not row["passed"]
                summary.retried += retries > 0
                summary.retries += retries
                if on_row is not None:
                    on_row(row)
                status = f"passed {summary.ok - checks_failed}"
                if checks_failed:
                    status += f", [yellow]failed checks {checks_failed}[/yellow]"
                if summary.failed:
                    status += f", [red]errored {summary.failed}[/red]"
                if summary.retries:
                    status += f", retried {summary.retried}"
                progress.update(task, advance=1, status=status)
    finally:
        summary.not_run += len(futures) - done
        client.cancel([f for f in futures if not f.done()])
