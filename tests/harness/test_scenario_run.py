"""The runner's pure parts: metric bounds, fleet totals, tracebacks; `swarmsitl run` bad input."""

import json

import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.report.totals import fleet_totals, lookup, metric_checks
from harness.scenarios.runner import traceback_in

pytestmark = pytest.mark.sockets

REPORT = {
    "vehicles": {
        "vehicle1": {
            "max_tilt": {"value": 12.5, "unit": "deg"},
            "companion": {
                "spills_seen": {"value": 3, "unit": "count"},
                "coverage_fraction": {"value": 1.0, "unit": "1"},
                "note": {"value": "fine", "unit": ""},
                "found": {"value": ["spill_3", "spill_1"], "unit": "names"},
            },
        },
        "vehicle2": {
            "max_tilt": {"value": 20.0, "unit": "deg"},
            "companion": {
                "spills_seen": {"value": 4, "unit": "count"},
                "coverage_fraction": {"value": 0.5, "unit": "1"},
                "found": {"value": ["spill_1", "spill_2"], "unit": "names"},
            },
        },
        "vehicle3": {"max_tilt": {"value": 1.0, "unit": "deg"}},
    }
}


def test_fleet_totals_add_counts_and_average_shares():
    totals = fleet_totals(REPORT)
    assert totals["spills_seen"] == {
        "value": 7, "unit": "count", "sum": 7, "mean": 3.5, "vehicles": 2
    }  # fmt: skip
    assert totals["coverage_fraction"]["value"] == pytest.approx(0.75)
    assert "note" not in totals  # not a number
    # lists: what the fleet found, each thing once however many vehicles found it
    assert totals["found"] == {
        "value": 3, "unit": "distinct", "items": ["spill_1", "spill_2", "spill_3"], "vehicles": 2
    }  # fmt: skip


def test_metric_bounds_pass_fail_and_missing():
    report = REPORT | {"fleet": {"companions": fleet_totals(REPORT)}}
    assert lookup(report, "vehicles.vehicle2.max_tilt") == 20.0
    checks = metric_checks(
        report,
        {
            "fleet.companions.spills_seen": (5, None),
            "vehicles.vehicle2.max_tilt": (None, 15.0),
            "vehicles.vehicle9.max_tilt": (None, 15.0),
        },
    )
    assert checks["metric fleet.companions.spills_seen"]["ok"]
    assert not checks["metric vehicles.vehicle2.max_tilt"]["ok"]
    missing = checks["metric vehicles.vehicle9.max_tilt"]
    assert not missing["ok"] and "not in report" in missing["message"]


def test_the_first_traceback_is_the_crash(tmp_path):
    log = tmp_path / "companion.log"
    log.write_text(
        "[coverage] connected\n"
        'Traceback (most recent call last):\n  File "x.py", line 3, in fly\n'
        "RuntimeError: deliberately broken\n"
        "Exception ignored in atexit callback\n"
        'Traceback (most recent call last):\n  File "system.py"\n'
        "ImportError: sys.meta_path is None, Python is likely shutting down\n"
    )
    text = traceback_in(log)
    assert "deliberately broken" in text and "shutting down" not in text
    log.write_text("killed without a word\n")
    assert traceback_in(log) == "killed without a word\n"
    assert traceback_in(tmp_path / "absent.log") is None


def test_run_rejects_a_bad_scenario_before_anything_starts(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nduration_s: 10\nfleet: [{role: a, colour: red}]\nroles: {a: {}}\n")
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(bad), "--out", str(out)])
    assert result.exit_code == 2
    assert "bad.yaml:3: fleet.0.colour: unknown key" in " ".join(result.output.split())
    assert not out.exists()  # nothing started, nothing written


def test_run_help_has_an_example():
    for command in ("run", "demo", "first-flight"):
        result = CliRunner().invoke(app, [command, "--help"], env={"COLUMNS": "200"})
        assert result.exit_code == 0 and "Example:" in result.output


def test_a_run_without_companions_runs_its_duration_and_reports(tmp_path):
    """No companion: vehicles stand on the ground for the whole duration; the report is whole."""
    scenario = tmp_path / "idle.yaml"
    scenario.write_text(
        "name: idle\nduration_s: 3\nworld: example:taskmap\nfleet: [{role: idle, count: 2}]\n"
        "roles: {idle: {}}\nsensors: {cameras: false, rangefinders: false}\n"
        "checks: {landed_and_disarmed: true, stay_inside_world: true}\n"
    )
    out = tmp_path / "run"
    args = ["run", str(scenario), "--out", str(out), "--sdk-port", "0", "--listen-port", "0",
            "--payload-port", "0"]  # fmt: skip
    result = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] and report["stop_reason"] == "duration"
    assert report["sim_time_s"] == pytest.approx(3.0, abs=0.01)
    assert report["checks"]["landed_and_disarmed"]["ok"]
    assert report["companions"] == {}
    assert (out / "plots" / "map.png").is_file() and (out / "world.yaml").is_file()


def test_groups_start_in_their_own_launch_areas_and_a_full_area_is_refused(tmp_path):
    from harness.scenarios.runner import RunOptions, ScenarioRun
    from harness.scenarios.spec import load_scenario

    scenario = tmp_path / "two_starts.yaml"
    scenario.write_text(
        "name: starts\nduration_s: 5\nworld: example:taskmap\n"
        "fleet:\n  - {role: a, launch_area: agent_start_3}\n"
        "  - {role: b, start_enu_m: [[1, 2, 0]]}\n"
        "roles: {a: {}, b: {}}\n"
    )
    loaded = load_scenario(scenario)
    run = ScenarioRun(loaded, RunOptions(tmp_path / "run"))
    area = loaded.world.launch_area("agent_start_3").center_enu_m
    assert run.spawn_enu_m.tolist() == [list(area), [1.0, 2.0, 0.0]]
    assert run._simulation_config().world_config().spawn_enu_m[1] == (1.0, 2.0, 0.0)

    crowded = tmp_path / "crowded.yaml"
    crowded.write_text(
        "name: crowded\nduration_s: 5\nworld: example:offshore\nlaunch_area: helideck\n"
        "fleet: [{role: a, count: 40}]\nroles: {a: {}}\n"
    )
    result = CliRunner().invoke(app, ["run", str(crowded), "--out", str(tmp_path / "c")])
    assert result.exit_code == 2
    assert "helideck" in result.output and "Traceback" not in result.output
