"""Plots of a sweep: each metric's mean over seeds with its 95 % confidence interval.

One PNG per metric (``plots/METRIC.png``): the mean over the seeds of the trials that finished
``ok`` against the sweep's x parameter, one line per combination of the other grid parameters,
and a band for the 95 % confidence interval of the mean (Student t with n - 1 degrees of
freedom: mean +- t * s / sqrt(n)). The band is drawn only where a point has at least
``MIN_SEEDS_FOR_BAND`` (3) seeds: with 2, t(0.975, 1) = 12.7 makes an interval that says nothing
but "too few seeds" (and for a non-negative metric it mostly lies below zero). A band never
leaves the metric's range (``metric_range``): a metric that no trial reported below 0 (counts,
distances, energies) is clipped at 0, a fraction at 1, a percentage at 100. The x axis is
logarithmic when the x values are positive and span more than a decade (1, 10, 100, 1000 nodes).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from scipy import stats

from harness.sweep.table import unit_of

CONFIDENCE = 0.95
"""Level of the plotted confidence interval of each mean."""
MIN_SEEDS_FOR_BAND = 3
"""Fewest values of a point for which its confidence band is drawn (n - 1 >= 2 degrees of
freedom; with n = 2 the t quantile is 12.7 and the band is as wide as the data allow)."""
FRACTION_UNITS = frozenset({"1", "bool", ""})
"""Units of a metric that is a share when all its values are in [0, 1] (plus no unit)."""
PERCENT_UNITS = frozenset({"%"})
"""Units of a metric that is a share in [0, 100] when all its values are."""

Range = tuple[float | None, float | None]
"""(lowest, highest) value a metric can take; None: unbounded on that side."""


@dataclass(frozen=True)
class MeanCI:
    """A point's mean over its seeds and the confidence band drawn for it.

    ``low`` and ``high`` are nan when there is no band (fewer than ``MIN_SEEDS_FOR_BAND``
    values); otherwise they are the Student-t interval clipped to the metric's range.
    """

    mean: float
    low: float
    high: float
    n: int

    @property
    def has_band(self) -> bool:
        """Whether a band is drawn for this point."""
        return not (math.isnan(self.low) or math.isnan(self.high))


def _finite(values: Iterable[Any]) -> np.ndarray:
    return np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)


def metric_range(values: Iterable[Any], unit: str | None = None) -> Range:
    """The range a metric is taken to have, from its observed values and its unit.

    Lower bound 0 when no observed value is negative (counts, distances, energies, durations);
    upper bound 1 when, besides, none is above 1 and the unit is dimensionless (``1``, ``bool``,
    none): a fraction or a share of booleans; upper bound 100 for a percentage in [0, 100].
    A count whose observed values happen to be 0 and 1 keeps no upper bound (its unit says
    ``count``). A metric with a negative value anywhere is unbounded.
    """
    x = _finite(values)
    if len(x) == 0 or x.min() < 0:
        return None, None
    top = float(x.max())
    if (unit is None or unit in FRACTION_UNITS) and top <= 1:
        return 0.0, 1.0
    if unit in PERCENT_UNITS and top <= 100:
        return 0.0, 100.0
    return 0.0, None


def mean_ci(
    values: Iterable[Any], level: float = CONFIDENCE, bounds: Range = (None, None)
) -> MeanCI:
    """Mean of the finite values and its ``level`` Student-t interval, clipped to ``bounds``.

    No band (nan ``low`` and ``high``) for fewer than ``MIN_SEEDS_FOR_BAND`` values.
    """
    x = _finite(values)
    n = len(x)
    if n == 0:
        return MeanCI(math.nan, math.nan, math.nan, 0)
    mean = float(x.mean())
    if n < MIN_SEEDS_FOR_BAND:
        return MeanCI(mean, math.nan, math.nan, n)
    half = float(stats.t.ppf(0.5 + level / 2, n - 1)) * float(x.std(ddof=1)) / math.sqrt(n)
    low, high = mean - half, mean + half
    lowest, highest = bounds
    if lowest is not None:
        low = max(low, lowest)
    if highest is not None:
        high = min(high, highest)
    return MeanCI(mean, low, high, n)


def _numeric(values: list[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def _label(point: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {v}" for k, v in point.items())


Bands = dict[str, list[MeanCI]]
"""A line's label (the other grid parameters' values; "" without any) -> its points along x."""


def metric_bands(
    rows: list[dict[str, Any]],
    grid: dict[str, list[Any]],
    x_name: str,
    metric: str,
    unit: str | None = None,
) -> Bands:
    """Mean and band of ``metric`` at every x of every line (the numbers ``plot_metric`` draws).

    The metric's range comes from every row's value (``metric_range``), so all lines of a plot
    are clipped alike. Lines without any value are left out.
    """
    xs = list(grid[x_name])
    others = {k: v for k, v in grid.items() if k != x_name}
    bounds = metric_range((r.get(metric) for r in rows), unit)
    bands: Bands = {}
    for combo in itertools.product(*others.values()):
        point = dict(zip(others, combo, strict=True))
        line = [
            mean_ci(
                (
                    r.get(metric)
                    for r in rows
                    if r[x_name] == xv and all(r[k] == v for k, v in point.items())
                ),
                bounds=bounds,
            )
            for xv in xs
        ]
        if any(p.n for p in line):
            bands[_label(point)] = line
    return bands


def plot_metric(
    rows: list[dict[str, Any]],
    grid: dict[str, list[Any]],
    x_name: str,
    metric: str,
    path: Path,
    unit: str | None = None,
) -> Bands:
    """One PNG: mean and confidence band of ``metric`` over ``x_name``, a line per other point.

    Returns what it drew (``metric_bands``). Where a point has fewer than ``MIN_SEEDS_FOR_BAND``
    values it has no band, and the plot says so below its title.
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import ScalarFormatter

    xs = list(grid[x_name])
    numeric = _numeric(xs)
    positions = [float(v) for v in xs] if numeric else list(range(len(xs)))
    bands = metric_bands(rows, grid, x_name, metric, unit)
    fig = Figure(figsize=(7.5, 4.8))
    ax = fig.add_subplot()
    for label, line in bands.items():
        means = [p.mean for p in line]
        (drawn,) = ax.plot(positions, means, "o-", lw=1.5, label=label or None)
        banded = [p.has_band for p in line]
        if any(banded):
            color = drawn.get_color()
            ax.fill_between(
                positions,
                [p.low if p.has_band else math.nan for p in line],
                [p.high if p.has_band else math.nan for p in line],
                where=banded,
                color=color,
                alpha=0.2,
                lw=0,
            )
            at = [k for k, b in enumerate(banded) if b]  # isolated points show as error bars
            ax.errorbar(
                [positions[k] for k in at],
                [line[k].mean for k in at],
                yerr=[
                    [line[k].mean - line[k].low for k in at],
                    [line[k].high - line[k].mean for k in at],
                ],
                fmt="none",
                ecolor=color,
                alpha=0.6,
                capsize=3,
            )
    if numeric and min(positions) > 0 and max(positions) / min(positions) > 10:
        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(ScalarFormatter())
    if not numeric:
        ax.set_xticks(positions, [str(v) for v in xs])
    ax.set_xlabel(x_name)
    ax.set_ylabel(f"{metric} [{unit}]" if unit else metric)
    title = f"{metric}: mean over seeds, {CONFIDENCE:.0%} confidence interval"
    if any(0 < p.n < MIN_SEEDS_FOR_BAND for line in bands.values() for p in line):
        title += f"\n(no band where a point has fewer than {MIN_SEEDS_FOR_BAND} seeds)"
    ax.set_title(title, fontsize="medium")
    ax.grid(True, alpha=0.3)
    if len(grid) > 1:
        ax.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return bands


def plot_sweep(
    table: pa.Table,
    grid: dict[str, list[Any]],
    x_name: str,
    metrics: list[str],
    plot_dir: Path,
    parameters: Iterable[str] = (),
) -> tuple[list[Path], list[str]]:
    """A PNG per metric (default: every ``fleet.`` metric) from the ``ok`` rows; paths, warnings.

    ``grid``: one column per axis of the grid -> its values; ``parameters``: every grid
    parameter's column besides (a coupled key's others), none of which is a metric.

    One warning when some plotted point has too few seeds for a band.
    """
    rows = [r for r in table.to_pylist() if r.get("status") == "ok"]
    columns = set(table.column_names) - set(parameters)
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
    fewest = None
    for metric in metrics:
        if metric not in columns:
            known = ", ".join(sorted(c for c in columns - set(grid) if c.startswith("fleet.")))
            known = known or "none"
            warnings.append(f"metric {metric!r} is not a column of the table (metrics: {known})")
            continue
        path = plot_dir / f"{metric}.png"
        bands = plot_metric(rows, grid, x_name, metric, path, unit_of(table, metric))
        paths.append(path)
        counts = [p.n for line in bands.values() for p in line if p.n > 0]
        if counts:
            fewest = min(counts) if fewest is None else min(fewest, min(counts))
    if fewest is not None and fewest < MIN_SEEDS_FOR_BAND:
        warnings.append(
            f"some plotted points have only {fewest} seed(s) that finished ok: no confidence "
            f"band there (a band needs at least {MIN_SEEDS_FOR_BAND}; set seeds: "
            f"{MIN_SEEDS_FOR_BAND} or more)"
        )
    return paths, warnings
