"""``swarm_prediction``: a scenario's swarm-fidelity run set beside a full run's report.

No process: the scenario (mco_urban, every vehicle flies its MCO task) runs at fidelity swarm in
this process, against a hand-made full-fidelity report.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.experiments.seed004 import RESERVE_SOC
from harness.report.swarm_prediction import swarm_prediction
from harness.scenarios.spec import load_scenario

SCENARIO = Path(__file__).parents[2] / "src/harness/scenarios/mco_urban.yaml"


def _full_report(soc: dict[str, float | None]) -> dict:
    """A full run's report with these final states of charge (None: the metric missing)."""
    vehicles = {}
    for name, value in soc.items():
        entry = {"airborne_time": {"value": 300.0, "unit": "s"},
                 "distance_flown": {"value": 2000.0, "unit": "m"}}  # fmt: skip
        if value is not None:
            entry["final_battery_soc"] = {"value": value, "unit": "fraction"}
        vehicles[name] = entry
    return {"vehicles": vehicles}


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(SCENARIO)


def test_each_vehicle_gets_the_swarm_battery_beside_the_full_one(scenario):
    """Per vehicle: the full run's charge in %, the swarm run's, their difference (swarm minus
    full); the swarm drain matches the fleet file's hover endurance to the reserve (the
    flight_time_s trait: 100 - RESERVE % over that time) within 3 pp."""
    full = {"vehicle1": 0.7, "vehicle2": 0.6, "vehicle3": 0.65, "vehicle4": None}
    out = swarm_prediction(scenario, scenario.spec.seed, _full_report(full))
    assert out["complete"] and out["passed"], out
    assert set(out["vehicles"]) == set(full)
    traits = scenario.spec.fleet[0].traits["flight_time_s"]
    for k, (name, soc) in enumerate(full.items()):
        v = out["vehicles"][name]
        swarm, airborne = v["battery_remaining_swarm"], v["airborne_time_swarm"]
        assert 0.0 < swarm < 100.0 and airborne > 60.0, v
        expected = 100.0 - (100.0 - 100.0 * RESERVE_SOC) * airborne / traits[k]
        assert swarm == pytest.approx(expected, abs=3.0), (name, v, expected)
        if soc is None:
            assert v["battery_remaining_full"] is None and v["battery_difference"] is None
        else:
            assert v["battery_remaining_full"] == pytest.approx(100.0 * soc)
            assert v["battery_difference"] == pytest.approx(swarm - 100.0 * soc, abs=0.01)
    diffs = [abs(v["battery_difference"]) for v in out["vehicles"].values()
             if v["battery_difference"] is not None]  # fmt: skip
    assert out["battery_difference_max_abs"] == pytest.approx(max(diffs), abs=0.01)


def test_a_vehicle_the_swarm_run_does_not_have_gets_no_swarm_figure(scenario):
    """A vehicle name only the full report has: no swarm battery, no difference, no mean."""
    out = swarm_prediction(scenario, scenario.spec.seed, _full_report({"vehicle9": 0.5}))
    v = out["vehicles"]["vehicle9"]
    assert v["battery_remaining_full"] == pytest.approx(50.0)
    assert v["battery_remaining_swarm"] is None and v["battery_difference"] is None
    assert out["battery_difference_mean_abs"] is None
