"""One trial -> one row: the scenario with its parameters and seed, every failure kept as data."""

import math
from pathlib import Path

from harness.report.totals import lookup
from harness.sweep.trial import (
    UNITS_KEY,
    Trial,
    build_scenario,
    flatten_metrics,
    metric_units,
    run_trial,
)

DATA = Path(__file__).with_name("data")

REPORT = {
    "passed": True,
    "complete": True,
    "sim_time_s": 30.0,
    "fleet": {
        "vehicles": {"value": 3, "unit": "count"},
        "min_separation": {"value": 4.5, "unit": "m", "between": ["vehicle1", "vehicle2"]},
        "failsafe_texts": {"value": 0, "unit": "count", "texts": []},
        "all_landed": {"value": True, "unit": "bool"},
        "final_mode": {"value": "LAND", "unit": ""},
        "energy_j": 1234.5,
        "companions": {
            "spills_seen": {"value": 2, "unit": "count", "sum": 2, "mean": 0.67},
            "targets": {"value": ["a", "b"], "unit": "distinct"},
        },
    },
}


def trial(**values):
    text = (DATA / "tiny.yaml").read_text()
    return Trial("t1", str(DATA / "tiny.yaml"), text, tuple(values.items()), 7)


def test_flattened_metrics_carry_the_names_checks_metrics_resolve():
    flat = flatten_metrics(REPORT)
    assert flat == {
        "fleet.vehicles": 3.0,
        "fleet.min_separation": 4.5,
        "fleet.failsafe_texts": 0.0,
        "fleet.all_landed": 1.0,
        "fleet.energy_j": 1234.5,
        "fleet.companions.spills_seen": 2.0,
    }
    for name, value in flat.items():
        assert float(lookup(REPORT, name)) == value
    assert metric_units(REPORT) == {
        "fleet.vehicles": "count",
        "fleet.min_separation": "m",
        "fleet.failsafe_texts": "count",
        "fleet.all_landed": "bool",
        "fleet.companions.spills_seen": "count",
    }


def test_the_trial_scenario_has_the_parameters_and_the_seed():
    scenario = build_scenario(trial(**{"fleet.0.count": 5, "swarm.step_hz": 20.0}))
    assert scenario.spec.n_vehicles == 5
    assert scenario.spec.swarm.step_hz == 20.0
    assert scenario.spec.seed == 7
    assert scenario.path == DATA / "tiny.yaml"


def test_a_trial_runs_its_body_and_fills_the_row():
    seen = []

    def body(scenario, seed, run_dir, timeout_wall_s):
        seen.append((scenario.spec.n_vehicles, seed, run_dir))
        return REPORT

    row = run_trial(trial(**{"fleet.0.count": 4}), body)
    assert seen == [(4, 7, None)]
    assert row["status"] == "ok"
    assert row["error"] == ""
    assert row["fleet.0.count"] == 4
    assert row["seed"] == 7
    assert row["passed"] is True
    assert row["sim_time_s"] == 30.0
    assert row["fleet.companions.spills_seen"] == 2.0
    assert row[UNITS_KEY]["fleet.min_separation"] == "m"
    assert row["wall_s"] >= 0


def test_an_exception_in_a_trial_becomes_a_failed_row_with_its_traceback():
    def body(scenario, seed, run_dir, timeout_wall_s):
        raise ZeroDivisionError("the trial divided by zero")

    row = run_trial(trial(**{"fleet.0.count": 4}), body)
    assert row["status"] == "failed"
    assert "Traceback" in row["error"]
    assert "ZeroDivisionError: the trial divided by zero" in row["error"]
    assert row["fleet.0.count"] == 4
    assert math.isnan(row["sim_time_s"])
    assert not any(k.startswith("fleet.") and k != "fleet.0.count" for k in row)


def test_a_value_the_scenario_rejects_at_run_time_is_a_failed_row_too():
    row = run_trial(trial(**{"fleet.0.count": -1}), lambda *a: REPORT)
    assert row["status"] == "failed"
    assert "ScenarioError" in row["error"]


def test_a_report_without_metrics_is_a_failed_row_naming_its_error():
    row = run_trial(trial(), lambda *a: {"error": "the simulation did not start"})
    assert row["status"] == "failed"
    assert "the run wrote no metrics: the simulation did not start" in row["error"]
