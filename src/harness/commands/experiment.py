"""``swarmsitl experiment NAME``: a seed paper reproduced on the sweep machinery."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from harness.run.launch import console

EXPERIMENTS = ("seed001", "seed003", "seed004")
"""The experiments there are (docs/seed001.md, docs/seed003.md, docs/seed004.md)."""
EXIT_FAILED = 1
"""A trial errored or failed its checks (its row says which); the tables are still written."""
EXIT_BAD_INPUT = 2
"""An unknown experiment, a bad option, or a case that cannot be planned: nothing ran."""


def experiment(
    name: Annotated[str, typer.Argument(help=f"the experiment: one of {', '.join(EXPERIMENTS)}")],
    out: Annotated[
        Path, typer.Option(help="output directory (reused to resume), e.g. runs/seed004")
    ],
    quick: Annotated[
        bool,
        typer.Option("--quick", help="fewer cells and runs (under 5 minutes on 2 cores)"),
    ] = False,
    seeds: Annotated[
        int | None,
        typer.Option(
            "--runs",
            "--seeds",
            min=1,
            help="runs (seeds) per cell: seed001 35 for Table 2 and at most 10 for the sweeps "
            "(--quick 2), seed003 31 (--quick 5), seed004 10 (--quick 2)",
        ),
    ] = None,
    workers: Annotated[
        int, typer.Option(min=1, help="worker processes of the local Dask cluster")
    ] = 2,
    scheduler: Annotated[
        str | None,
        typer.Option(
            metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://10.0.0.5:8786"
        ),
    ] = None,
) -> None:
    """Reproduce a seed paper: every case x seed as a sweep trial, then tables and plots.

    Writes OUT/results.parquet (one row per run), OUT/tables.md (our means and 95 % intervals
    beside every number the paper prints), OUT/plots/ and OUT/sweep/ (the sweep's own rows: a
    second run of the same command resumes), and ends with a line `RESULT key=value ...`.
    Exit status: 0 when every run passed its checks, 1 when one errored or failed them, 2 for
    bad input (nothing ran).

    Example:  swarmsitl experiment seed001 --quick --out runs/seed001-quick

    Example:  swarmsitl experiment seed003 --quick --out runs/seed003-quick

    Example:  swarmsitl experiment seed003 --runs 31 --workers 2 --out runs/seed003

    Example:  swarmsitl experiment seed004 --quick --out runs/seed004-quick

    Example:  swarmsitl experiment seed004 --seeds 10 --workers 2 --out runs/seed004
    """
    if name not in EXPERIMENTS:
        console.print(
            f"[red]error:[/red] no experiment {escape(name)!r}; one of {list(EXPERIMENTS)}"
        )
        raise typer.Exit(EXIT_BAD_INPUT)
    import importlib

    module = importlib.import_module(f"harness.experiments.{name}")
    try:
        cfg = module.make_config(quick, seeds)
        status = module.run_experiment(
            cfg, out.absolute(), workers=workers, scheduler=scheduler, console=console,
            say=lambda text: console.print(text, markup=False, highlight=False, soft_wrap=True),
        )  # fmt: skip
    except (module.ExperimentError, OSError) as exc:  # a case that cannot be planned (nothing
        # ran), a bad --seeds, or no scheduler at --scheduler
        console.print(f"[red]error:[/red] {escape(str(exc))}")
        raise typer.Exit(EXIT_BAD_INPUT) from exc
    if status:
        raise typer.Exit(EXIT_FAILED)
