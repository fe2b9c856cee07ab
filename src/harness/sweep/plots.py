"""Plots of a sweep: each metric's mean over seeds with its 95 % confidence interval.

One PNG per metric (``plots/METRIC.png``): the mean over the seeds of the trials that finished
``ok`` against the sweep's x parameter, one line per combination of the other grid parameters,
and a band for the 95 % confidence interval of the mean (Student t with n - 1 degrees of
freedom: mean +- t * s / sqrt(n); no band where a point has one seed). The x axis is logarithmic
when the x values are positive and span more than a decade (1, 10, 100, 1000 nodes).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from scipy import stats

from harness.sweep.table import unit_of

CONFIDENCE = 0.95
"""Level of the plotted confidence interval of each mean."""


def mean_ci(values: list[float], level: float = CONFIDENCE) -> tuple[float, float, int]:
    """Mean, half width of its ``level`` Student-t confidence interval (nan for n < 2), n."""
    x = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    n = len(x)
    if n == 0:
        return math.nan, math.nan, 0
    mean = float(x.mean())
    if n < 2:
        return mean, math.nan, 1
    sem = float(x.std(ddof=1)) / math.sqrt(n)
    return mean, float(stats.t.ppf(0.5 + level / 2, n - 1)) * sem, n


def _numeric(values: list[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _label(point: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in point.items())


def plot_metric(
    rows: list[dict[str, Any]],
    grid: dict[str, list[Any]],
    x_name: str,
    metric: str,
    path: Path,
    unit: str | None = None,
) -> None:
    """One PNG: mean and confidence band of ``metric`` over ``x_name``, a line per other point."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import ScalarFormatter

    xs = list(grid[x_name])
    others = {k: v for k, v in grid.items() if k != x_name}
    numeric = _numeric(xs)
    positions = [float(v) for v in xs] if numeric else list(range(len(xs)))
    fig = Figure(figsize=(7.5, 4.8))
    ax = fig.add_subplot()
    for combo in itertools.product(*others.values()):
        point = dict(zip(others, combo, strict=True))
        means, lows, highs = [], [], []
        for xv in xs:
            values = [
                r.get(metric)
                for r in rows
                if r[x_name] == xv and all(r[k] == v for k, v in point.items())
            ]
            mean, half, _ = mean_ci(values)
            means.append(mean)
            lows.append(mean - half)
            highs.append(mean + half)
        if all(math.isnan(m) for m in means):
            continue
        (line,) = ax.plot(positions, means, "o-", lw=1.5, label=_label(point) or None)
        ax.fill_between(positions, lows, highs, color=line.get_color(), alpha=0.2, lw=0)
    if numeric and min(positions) > 0 and max(positions) / min(positions) > 10:
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
    if not numeric:
        ax.set_xticks(positions, [str(v) for v in xs])
    ax.set_xlabel(x_name)
    ax.set_ylabel(f"{metric} [{unit}]" if unit else metric)
    ax.set_title(f"{metric}: mean over seeds, {CONFIDENCE:.0%} confidence interval")
    ax.grid(True, alpha=0.3)
    if others:
        ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_sweep(
    table: pa.Table,
    grid: dict[str, list[Any]],
    x_name: str,
    metrics: list[str],
    plot_dir: Path,
) -> tuple[list[Path], list[str]]:
    """A PNG per metric (default: every ``fleet.`` metric) from the ``ok`` rows; paths, warnings."""
    rows = [r for r in table.to_pylist() if r.get("status") == "ok"]
    columns = set(table.column_names)
    if not metrics:
        metrics = sorted(
            c
            for c in columns - set(grid)
            if c.startswith("fleet.") and any(r.get(c) is not None for r in rows)
        )
    warnings = []
    paths = []
    if not rows:
        return [], ["no trial finished ok: no plots"]
    plot_dir.mkdir(parents=True, exist_ok=True)
    for metric in metrics:
        if metric not in columns:
            known = ", ".join(sorted(c for c in columns - set(grid) if c.startswith("fleet.")))
            known = known or "none"
            warnings.append(f"metric {metric!r} is not a column of the table (metrics: {known})")
            continue
        path = plot_dir / f"{metric}.png"
        plot_metric(rows, grid, x_name, metric, path, unit_of(table, metric))
        paths.append(path)
    return paths, warnings
