"""Means and 95 % confidence intervals for the experiments' tables."""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
from scipy import stats


def mean_ci95(values: Iterable[float]) -> tuple[float, float, int]:
    """(mean, half-width of the 95 % Student-t interval, count) of the finite values.

    The half-width is NaN with fewer than two values, and the mean NaN with none.
    """
    x = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if len(x) == 0:
        return math.nan, math.nan, 0
    if len(x) == 1:
        return float(x[0]), math.nan, 1
    sem = float(np.std(x, ddof=1)) / math.sqrt(len(x))
    return float(np.mean(x)), float(stats.t.ppf(0.975, len(x) - 1) * sem), len(x)


def format_ci(mean: float, half: float, digits: int = 1) -> str:
    """``12.3 ± 0.4`` (``12.3`` without an interval, ``-`` without a value)."""
    if not math.isfinite(mean):
        return "-"
    if not math.isfinite(half):
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"
