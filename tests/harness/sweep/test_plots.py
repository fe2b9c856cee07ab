"""Plots: the mean over seeds and its Student-t confidence interval, a PNG per metric."""

import math

import pyarrow as pa
import pytest
from scipy import stats

from harness.sweep.plots import mean_ci, plot_sweep


def test_the_interval_is_scipys_student_t_interval_of_the_mean():
    values = [0.61, 0.72, 0.58, 0.66, 0.70]
    mean, half, n = mean_ci(values)
    low, high = stats.t.interval(0.95, len(values) - 1, loc=mean, scale=stats.sem(values))
    assert n == 5
    assert mean == pytest.approx(sum(values) / 5)
    assert (mean - half, mean + half) == pytest.approx((low, high))


def test_one_seed_has_a_mean_and_no_interval_and_missing_values_are_left_out():
    mean, half, n = mean_ci([None, 2.0, math.nan])
    assert (mean, n) == (2.0, 1)
    assert math.isnan(half)
    assert mean_ci([])[2] == 0


def table(rows):
    return pa.Table.from_pylist(rows)


def test_a_png_per_metric_defaults_to_the_fleet_metrics_not_the_grid_parameters(tmp_path):
    rows = [
        {"fleet.0.count": n, "mode": m, "seed": s, "status": "ok", "fleet.coverage": n * 0.1 + s,
         "fleet.events": 1.0}
        for n in (1, 10, 100) for m in ("a", "b") for s in (0, 1)
    ]  # fmt: skip
    rows.append({"fleet.0.count": 1, "mode": "a", "seed": 2, "status": "failed"})
    grid = {"fleet.0.count": [1, 10, 100], "mode": ["a", "b"]}
    paths, warnings = plot_sweep(table(rows), grid, "fleet.0.count", [], tmp_path)
    assert sorted(p.name for p in paths) == ["fleet.coverage.png", "fleet.events.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)
    assert warnings == []


def test_a_metric_no_trial_reported_is_a_warning_naming_those_there_are(tmp_path):
    rows = [{"duration_s": 10, "status": "ok", "fleet.coverage": 0.5}]
    paths, warnings = plot_sweep(
        table(rows), {"duration_s": [10]}, "duration_s", ["fleet.coverag"], tmp_path
    )
    assert paths == []
    assert warnings == [
        "metric 'fleet.coverag' is not a column of the table (metrics: fleet.coverage)"
    ]


def test_no_ok_trial_no_plot(tmp_path):
    rows = [{"duration_s": 10, "status": "failed"}]
    paths, warnings = plot_sweep(table(rows), {"duration_s": [10]}, "duration_s", [], tmp_path)
    assert paths == []
    assert warnings == ["no trial finished ok: no plots"]
