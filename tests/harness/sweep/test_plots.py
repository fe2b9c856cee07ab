"""Plots: the mean over seeds and its Student-t confidence interval, a PNG per metric."""

import math

import pyarrow as pa
import pytest
from scipy import stats

from harness.sweep.plots import (
    MIN_SEEDS_FOR_BAND,
    mean_ci,
    metric_bands,
    metric_range,
    plot_metric,
    plot_sweep,
)


def test_the_interval_is_scipys_student_t_interval_of_the_mean():
    values = [0.61, 0.72, 0.58, 0.66, 0.70]
    ci = mean_ci(values)
    low, high = stats.t.interval(0.95, len(values) - 1, loc=ci.mean, scale=stats.sem(values))
    assert ci.n == 5
    assert ci.mean == pytest.approx(sum(values) / 5)
    assert (ci.low, ci.high) == pytest.approx((low, high))
    assert ci.has_band


def test_one_or_two_seeds_have_a_mean_and_no_band_and_missing_values_are_left_out():
    assert MIN_SEEDS_FOR_BAND == 3
    one = mean_ci([None, 2.0, math.nan])
    assert (one.mean, one.n) == (2.0, 1)
    two = mean_ci([1.0, 3.0, None], bounds=(0.0, None))
    assert (two.mean, two.n) == (2.0, 2)
    for ci in (one, two):
        assert not ci.has_band
        assert math.isnan(ci.low) and math.isnan(ci.high)
    assert mean_ci([]).n == 0


def test_three_seeds_have_a_band_clipped_at_zero_for_a_non_negative_metric():
    values = [0.0, 0.0, 6.0]  # e.g. targets seen: mean 2, t(0.975, 2) * sem = 4.30 * 2 = 8.6
    raw = mean_ci(values)
    assert raw.low == pytest.approx(2.0 - stats.t.ppf(0.975, 2) * 2.0)
    assert raw.low < 0
    clipped = mean_ci(values, bounds=metric_range(values, "count"))
    assert clipped.has_band
    assert clipped.low == 0.0
    assert clipped.high == pytest.approx(raw.high)  # a count has no upper bound
    assert clipped.mean == raw.mean == 2.0


def test_a_fraction_is_clipped_to_zero_and_one():
    values = [1.0, 1.0, 0.2]
    ci = mean_ci(values, bounds=metric_range(values, "1"))
    assert mean_ci(values).high > 1 and mean_ci(values).low < 0
    assert (ci.low, ci.high) == (0.0, 1.0)


def test_the_range_of_a_metric_comes_from_its_values_and_its_unit():
    assert metric_range([0.0, 3.0, 12.5], "m") == (0.0, None)
    assert metric_range([0.0, 1.0, 1.0], "count") == (0.0, None)  # a count, not a share
    assert metric_range([0.2, 0.9], "1") == (0.0, 1.0)
    assert metric_range([0.0, 1.0], "bool") == (0.0, 1.0)
    assert metric_range([0.5, 0.7], None) == (0.0, 1.0)
    assert metric_range([1.5, 0.7], "1") == (0.0, None)
    assert metric_range([3.0, 100.0], "%") == (0.0, 100.0)
    assert metric_range([-0.1, 3.0], "m") == (None, None)
    assert metric_range([None, math.nan], "m") == (None, None)


def rows_with_seeds(seeds, values):
    """Rows of one metric at two x values: seed s has ``values[s]`` at x = 1 and 10 x it at 10."""
    return [
        {"n": n, "seed": s, "status": "ok", "fleet.seen": values[s] * (1 if n == 1 else 10)}
        for n in (1, 10)
        for s in range(seeds)
    ]


def test_the_plot_draws_no_band_for_two_seeds_and_says_so(tmp_path):
    rows = rows_with_seeds(2, [0.0, 4.0])
    bands = plot_metric(rows, {"n": [1, 10]}, "n", "fleet.seen", tmp_path / "p.png", "count")
    assert list(bands) == [""]
    assert [(ci.mean, ci.n, ci.has_band) for ci in bands[""]] == [(2.0, 2, False), (20.0, 2, False)]
    assert (tmp_path / "p.png").stat().st_size > 10_000
    paths, warnings = plot_sweep(table(rows), {"n": [1, 10]}, "n", [], tmp_path)
    assert [p.name for p in paths] == ["fleet.seen.png"]
    assert len(warnings) == 1
    assert "only 2 seed(s)" in warnings[0] and "no confidence band" in warnings[0]


def test_the_plot_clips_the_band_of_a_non_negative_metric_at_zero(tmp_path):
    rows = rows_with_seeds(3, [0.0, 0.0, 6.0])
    bands = metric_bands(rows, {"n": [1, 10]}, "n", "fleet.seen", "count")
    for ci in bands[""]:
        assert ci.n == 3 and ci.has_band
        assert ci.low == 0.0 < ci.mean < ci.high
    assert bands[""][1].high == pytest.approx(20.0 + stats.t.ppf(0.975, 2) * 20.0)
    paths, warnings = plot_sweep(table(rows), {"n": [1, 10]}, "n", [], tmp_path)
    assert len(paths) == 1 and warnings == []


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
    assert len(warnings) == 1 and "no confidence band" in warnings[0]  # 2 seeds a point


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


def test_a_coupled_keys_other_parameters_are_no_metrics_and_one_line_per_x(tmp_path):
    """``duration_s = fleet.0.count``: the axis is duration_s; fleet.0.count is not plotted."""
    rows = [
        {"duration_s": n, "fleet.0.count": n, "seed": s, "status": "ok", "fleet.coverage": n + s}
        for n in (1, 10) for s in (0, 1)
    ]  # fmt: skip
    paths, _ = plot_sweep(
        table(rows), {"duration_s": [1, 10]}, "duration_s", [], tmp_path,
        ["duration_s", "fleet.0.count"],
    )  # fmt: skip
    assert [p.name for p in paths] == ["fleet.coverage.png"]
    bands = metric_bands(rows, {"duration_s": [1, 10]}, "duration_s", "fleet.coverage")
    assert [p.mean for p in bands[""]] == [1.5, 10.5]
