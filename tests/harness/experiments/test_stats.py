"""Means and 95 % intervals of the experiments' tables."""

import math

import numpy as np
from scipy import stats

from harness.experiments.stats import format_ci, mean_ci95


def test_the_interval_is_students_t_of_the_sample() -> None:
    x = [1.0, 2.0, 4.0, 7.0]
    mean, half, count = mean_ci95(x)
    lo, hi = stats.t.interval(0.95, len(x) - 1, loc=np.mean(x), scale=stats.sem(x))
    assert count == 4
    assert math.isclose(mean, 3.5)
    assert math.isclose(half, (hi - lo) / 2)


def test_missing_values_are_left_out_and_one_value_has_no_interval() -> None:
    assert mean_ci95([math.nan, 5.0, None]) == (5.0, mean_ci95([5.0])[1], 1)  # type: ignore[list-item]
    assert math.isnan(mean_ci95([5.0])[1])
    mean, half, count = mean_ci95([])
    assert count == 0 and math.isnan(mean) and math.isnan(half)


def test_formatting() -> None:
    assert format_ci(12.345, 0.42) == "12.3 ± 0.4"
    assert format_ci(12.345, math.nan) == "12.3"
    assert format_ci(math.nan, math.nan) == "-"
