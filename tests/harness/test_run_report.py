"""The run report: metrics with units from the truth and tlogs, time series, plots, partial runs."""

import json

import numpy as np
import pytest
from rich.console import Console
from synthetic_run import two_vehicle_run

import worlds
from harness.report.run_report import TIMESERIES_COLUMNS, summary_table, write_run_report
from worlds.examples import example_path

EXTRA = {"seed": 7, "complete": True, "config_hash": "abc"}


def _strict_json(path):
    def refuse(name):
        raise ValueError(f"non-JSON constant {name}")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.fixture
def run(tmp_path):
    run_dir = tmp_path / "run"
    tracks = two_vehicle_run(run_dir, texts=[(1, 30.0, 2, "Geofence violation")])
    return run_dir, tracks


@pytest.fixture(scope="module")
def offshore():
    return worlds.build(worlds.load_world(example_path("offshore")))


def test_flight_metrics_follow_the_track(run):
    run_dir, tracks = run
    report = write_run_report(run_dir, None, None, EXTRA)
    m = report["vehicles"]["vehicle1"]
    # Up 10 m, 20 m east, 20 m north, down 10 m.
    assert m["distance_flown"] == {"value": pytest.approx(60.0, abs=0.01), "unit": "m"}
    # Above 0.3 m from 5.3 s (climbing 1 m/s from 5 s) to 44.7 s (sinking 1 m/s until 45 s).
    assert m["airborne_time"]["value"] == pytest.approx(39.4, abs=0.06)
    assert m["max_tilt"] == {"value": 5.0, "unit": "deg"}
    assert m["max_horizontal_speed"]["value"] == pytest.approx(2.0, abs=1e-3)  # 20 m in 10 s
    # 150 W in the air, 40 W armed on the ground (1 s either side), 3 W idle.
    expected_wh = (150.0 * 39.4 + 40.0 * 2.0 + 3.0 * (50.0 - 41.4)) / 3600.0
    assert m["energy_used"]["unit"] == "Wh"
    assert m["energy_used"]["value"] == pytest.approx(expected_wh, rel=0.01)
    assert m["final_battery_soc"]["value"] == pytest.approx(tracks[0]["battery_soc"][-1], abs=1e-5)
    assert m["landed_and_disarmed"]["value"] is True
    assert m["final_mode"]["value"] == "LOITER"
    fleet = report["fleet"]
    assert fleet["min_separation"]["value"] == pytest.approx(6.0, abs=1e-3)
    assert fleet["min_separation"]["between"] == ["vehicle1", "vehicle2"]
    assert fleet["failsafe_texts"]["value"] == 1
    assert fleet["failsafe_texts"]["texts"][0] == {
        "vehicle": "vehicle2",
        "time_s": 30.0,
        "text": "Geofence violation",
    }
    assert report["seed"] == 7 and report["complete"] is True
    assert _strict_json(run_dir / "report.json") == json.loads(json.dumps(report))


def test_estimation_error_is_estimate_from_spawn_minus_truth(tmp_path):
    run_dir = tmp_path / "run"
    tracks = two_vehicle_run(run_dir, spacing_m=6.0)
    # Vehicle 2's estimate (NED from its spawn at east 6 m) is 0.5 m north and 0.2 m low
    # after t = 20 s.
    late = tracks[1]["time_s"] > 20.0
    tracks[1]["est_north_m"] += np.where(late, 0.5, 0.0)
    tracks[1]["est_down_m"] += np.where(late, 0.2, 0.0)
    from synthetic_run import write_truth

    write_truth(run_dir / "truth.csv", tracks)
    spawns = np.array([[0.0, 0.0, 0.0], [6.0, 0.0, 0.0]])
    report = write_run_report(run_dir, None, spawns, {})
    m1, m2 = report["vehicles"]["vehicle1"], report["vehicles"]["vehicle2"]
    assert m1["est_error_horizontal_max"]["value"] == pytest.approx(0.0, abs=1e-4)
    assert m2["est_error_horizontal_max"]["value"] == pytest.approx(0.5, abs=1e-4)
    assert m2["est_error_vertical_max"]["value"] == pytest.approx(0.2, abs=1e-4)
    share = late.mean()
    assert m2["est_error_horizontal_rms"]["value"] == pytest.approx(0.5 * np.sqrt(share), rel=1e-3)
    series = np.loadtxt(run_dir / "timeseries" / "vehicle2.csv", delimiter=",", skiprows=1)
    header = (run_dir / "timeseries" / "vehicle2.csv").read_text().splitlines()[0]
    assert header == ",".join(TIMESERIES_COLUMNS)
    assert len(series) == len(tracks[1]["time_s"])
    np.testing.assert_allclose(series[:, 1], np.where(late, 0.5, 0.0), atol=1e-4)
    # Without spawn points the first truth samples stand in (the same pads here).
    again = write_run_report(run_dir, None, None, {})
    assert (
        again["vehicles"]["vehicle2"]["est_error_horizontal_rms"] == m2["est_error_horizontal_rms"]
    )
    # A wrong spawn point shows as an error of that size.
    wrong = write_run_report(run_dir, None, spawns + np.array([3.0, 4.0, 0.0]), {})
    assert wrong["vehicles"]["vehicle1"]["est_error_horizontal_max"]["value"] == pytest.approx(5.0)
    with pytest.raises(ValueError, match="spawn_enu_m"):
        write_run_report(run_dir, None, spawns[:1], {})


def test_companion_results_are_merged_per_vehicle(run):
    run_dir, _ = run
    (run_dir / "vehicle1").mkdir()
    (run_dir / "vehicle1" / "result.json").write_text(
        json.dumps({"spills_seen": {"value": 3, "unit": "count"}})
    )
    (run_dir / "vehicle2").mkdir()
    (run_dir / "vehicle2" / "result.json").write_text('{"spills_seen": ')  # crashed mid-write
    report = write_run_report(run_dir, None, None, {})
    assert report["vehicles"]["vehicle1"]["companion"] == {
        "spills_seen": {"value": 3, "unit": "count"}
    }
    assert "companion" not in report["vehicles"]["vehicle2"]
    assert any("vehicle2/result.json" in w and "unreadable" in w for w in report["warnings"])


def test_plots_and_series_are_written_with_and_without_a_world(run, offshore):
    run_dir, _ = run
    report = write_run_report(run_dir, offshore, None, {})
    for name in ("map.png", "errors.png", "battery.png"):
        data = (run_dir / "plots" / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000, name
        assert f"plots/{name}" in report["files"]
    with_world = (run_dir / "plots" / "map.png").read_bytes()
    write_run_report(run_dir, None, None, {})
    plain = (run_dir / "plots" / "map.png").read_bytes()
    assert plain != with_world
    assert (run_dir / "timeseries" / "vehicle1.csv").is_file()


def test_map_draws_every_kind_of_world_feature(tmp_path):
    """Arena (moving solids), workspace (no-fly holes, low-interest zones), indoor (people)."""
    for kind in ("arena_aco", "workspace_mco", "indoor", "city", "taskmap"):
        run_dir = tmp_path / kind
        two_vehicle_run(run_dir)
        world = worlds.build(worlds.load_world(example_path(kind)))
        write_run_report(run_dir, world, None, {})
        assert (run_dir / "plots" / "map.png").stat().st_size > 10_000


def test_a_partial_run_still_reports(run):
    run_dir, _ = run
    text = (run_dir / "truth.csv").read_text()
    (run_dir / "truth.csv").write_text(text[: len(text) // 3 + 11])
    data = (run_dir / "vehicle2.tlog").read_bytes()
    (run_dir / "vehicle2.tlog").write_bytes(data[: len(data) - 7])
    report = write_run_report(run_dir, None, None, {"complete": False})
    assert report["complete"] is False
    assert report["fleet"]["simulated_time"]["value"] < 20.0
    assert report["vehicles"]["vehicle1"]["landed_and_disarmed"]["value"] is False
    warned = " ".join(report["warnings"])
    assert "truth.csv" in warned and "vehicle2.tlog" in warned
    assert _strict_json(run_dir / "report.json")["complete"] is False
    assert (run_dir / "plots" / "map.png").is_file()


def test_an_older_truth_file_without_some_columns_reports_null(run):
    run_dir, _ = run
    path = run_dir / "truth.csv"
    rows = [line.split(",") for line in path.read_text().splitlines()]
    drop = {rows[0].index(c) for c in ("est_north_m", "est_east_m", "est_down_m", "landed_state")}
    path.write_text(
        "\n".join(",".join(x for k, x in enumerate(r) if k not in drop) for r in rows) + "\n"
    )
    report = write_run_report(run_dir, None, None, {})
    m = report["vehicles"]["vehicle1"]
    assert m["est_error_horizontal_rms"]["value"] is None
    assert m["distance_flown"]["value"] == pytest.approx(60.0, abs=0.01)
    assert m["landed_and_disarmed"]["value"] is False  # landed_state unknown
    assert any("est_north_m" in w and "NaN" in w for w in report["warnings"])
    _strict_json(run_dir / "report.json")


def test_a_run_without_truth_writes_a_report_saying_so(tmp_path):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    report = write_run_report(run_dir, None, None, {"complete": False, "seed": 1})
    assert "truth.csv" in report["error"]
    assert _strict_json(run_dir / "report.json")["seed"] == 1


def test_a_failing_plot_does_not_cost_the_report(run, monkeypatch):
    import harness.report.run_report as run_report

    def broken(*args):
        raise RuntimeError("no fonts")

    monkeypatch.setattr(run_report, "plot_map", broken)
    report = write_run_report(run[0], None, None, {"complete": True})
    assert any("no fonts" in w for w in report["warnings"])
    assert _strict_json(run[0] / "report.json")["vehicles"]["vehicle1"]["distance_flown"]


def test_summary_table_shows_vehicles_and_fleet(run):
    run_dir, _ = run
    report = write_run_report(run_dir, None, None, EXTRA)
    console = Console(record=True, width=220)
    console.print(summary_table(report))
    out = console.export_text()
    assert "vehicle1" in out and "vehicle2" in out
    assert "60 m" in out  # distance flown
    assert "min separation 6.0 m (vehicle1 / vehicle2" in out
    assert "failsafe texts: 1" in out


def _drawn_map(run_dir, world, seed):
    """The map's axes after drawing (limits settled by the equal aspect)."""
    from harness.report.flight_log import FlightLog
    from harness.report.run_report import _figure, draw_map

    fig, (ax,) = _figure((10.5, 8.0))
    draw_map(ax, FlightLog.load(run_dir, require_tlogs=False), world, seed)
    fig.canvas.draw()
    return ax


def test_the_map_frames_a_small_flight_not_the_whole_world(run):
    run_dir, tracks = run
    world = worlds.build(worlds.load_world(example_path("city")))
    ax = _drawn_map(run_dir, world, 42)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    for tr in tracks:
        assert x0 < tr["east_m"].min() and tr["east_m"].max() < x1
        assert y0 < tr["north_m"].min() and tr["north_m"].max() < y1
    minx, miny, maxx, maxy = world.boundary.bounds
    # A 26 m x 20 m flight: the view is tens of metres, the city hundreds.
    assert max(x1 - x0, y1 - y0) < 0.25 * min(maxx - minx, maxy - miny)
    assert min(x1 - x0, y1 - y0) >= 26.0


def test_the_map_title_carries_the_runs_seed_not_the_worlds(run, monkeypatch):
    import harness.report.run_report as run_report

    run_dir, _ = run
    world = worlds.build(worlds.load_world(example_path("city")))
    assert world.seed != 42
    title = _drawn_map(run_dir, world, 42).get_title()
    assert "run seed 42" in title and f"seed {world.seed}" not in title
    seeds = []
    monkeypatch.setattr(run_report, "plot_map", lambda path, log, world, seed: seeds.append(seed))
    write_run_report(run_dir, world, None, {"seed": 42})
    assert seeds == [42]


def test_a_swarm_map_frames_its_tracks(tmp_path, offshore, monkeypatch):
    import harness.report.run_report as run_report

    # Three vehicles flying 30 m east, 5 m apart, 100 samples: (T, N, 3).
    t = np.linspace(0.0, 1.0, 100)[:, None]
    east = 30.0 * t + np.arange(3) * 5.0
    tracks = np.stack((east, np.full_like(east, 2.0), np.full_like(east, 10.0)), axis=-1)
    drawn = []

    def keep(fig, path):
        fig.canvas.draw()
        drawn.append(fig.axes[0])

    monkeypatch.setattr(run_report, "_save", keep)
    run_report.plot_tracks(tmp_path / "map.png", tracks, offshore, 5)
    (ax,) = drawn
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert x0 < 0.0 and x1 > 40.0 and y0 < 2.0 < y1
    minx, _, maxx, _ = offshore.boundary.bounds
    assert x1 - x0 < 0.5 * (maxx - minx)
    assert "run seed 5" in ax.get_title()
