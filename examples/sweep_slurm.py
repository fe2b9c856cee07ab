r"""Run a swarmsitl sweep on a SLURM cluster through dask-jobqueue (docs/sweeps.md).

dask-jobqueue is not a dependency of swarmsitl; install it where swarmsitl is installed, on the
cluster's login node:

    pip install dask-jobqueue
    python examples/sweep_slurm.py examples/sweeps/coverage_1_to_1000.yaml \
        --queue regular --account myproject --jobs 4 --cores 16 --walltime 01:00:00 \
        --prologue "source $HOME/swarmsitl/.venv/bin/activate"

The sweep file (and the scenario of every grid point) is checked before any job is queued. Each
SLURM job runs ``--cores`` single-threaded Dask worker processes (one trial each at a time);
the rows, the table and the plots are written on the login node as the trials finish, so run
this in a ``tmux``/``screen`` session, and run it again to resume after an interruption.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from dask_jobqueue import SLURMCluster
from distributed import Client
from rich.console import Console

from harness.commands.sweep import exit_status
from harness.sweep.runner import run_sweep, worker_environment
from harness.sweep.spec import SweepError, plan_sweep


def main() -> int:
    """Plan the sweep, start the SLURM workers, run it, print the summary; the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep", type=Path, help="the sweep file (YAML)")
    parser.add_argument("--out", type=Path, help="output directory [runs/sweep-NAME]")
    parser.add_argument("--queue", help="SLURM partition (#SBATCH -p)")
    parser.add_argument("--account", help="SLURM account (#SBATCH -A)")
    parser.add_argument("--jobs", type=int, default=4, help="SLURM jobs (nodes) at most")
    parser.add_argument("--cores", type=int, default=16, help="cores per job = worker processes")
    parser.add_argument("--memory", default="32GB", help="memory per job (e.g. 32GB)")
    parser.add_argument("--walltime", default="01:00:00", help="wall time per job, HH:MM:SS")
    parser.add_argument(
        "--prologue",
        action="append",
        default=[],
        help="shell line run in each job before its workers start (repeatable)",
    )
    parser.add_argument(
        "--print-job-script", action="store_true", help="print the job script and exit"
    )
    args = parser.parse_args()
    try:
        plan = plan_sweep(args.sweep)
    except SweepError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    exports = [f"export {k}={shlex.quote(v)}" for k, v in worker_environment().items()]
    cluster = SLURMCluster(
        queue=args.queue,
        account=args.account,
        cores=args.cores,
        processes=args.cores,  # one single-threaded worker process per core
        memory=args.memory,
        walltime=args.walltime,
        # the settings of swarmsitl's own local cluster (no profiler, no MALLOC_TRIM_THRESHOLD_)
        job_script_prologue=[*exports, *args.prologue],
        log_directory="dask-logs",
    )
    try:
        if args.print_job_script:
            print(cluster.job_script())
            return 0
        cluster.adapt(minimum_jobs=1, maximum_jobs=args.jobs)  # fewer jobs once trials run out
        console = Console()
        out = args.out or Path("runs") / f"sweep-{plan.name}"
        with Client(cluster) as client:
            summary = run_sweep(plan, out, client=client, console=console)
        console.print(summary.describe(), markup=False, highlight=False)
        console.print(f"table: {summary.table}", markup=False, highlight=False)
        return exit_status(summary.outcome)  # as swarmsitl sweep: 1 errored, 3 failed checks
    finally:
        cluster.close()


if __name__ == "__main__":
    sys.exit(main())
