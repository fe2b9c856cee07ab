"""Seed 004's MCO plan on the full stack: ``swarmsitl run src/harness/scenarios/mco_urban.yaml``.

Real processes (the runner, one MAVSDK-Python companion ``companion.scripts.mco_plan`` per
vehicle, mavsdk_server, UDP), lockstep, free ports from the plugin's ``swarmsitl_ports``. Four
heterogeneous x500s each plan the whole coverage of the Urban Zone, fly their own task as a
MAVSDK mission and land; the run then predicts the same flights at fidelity swarm.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from companion.planning.mco.plan import McoParams
from companion.planning.mco.role import cached_plan, fleet_bidders
from companion.role_params import params_from_mapping
from harness.scenarios import scenario_path
from harness.scenarios.spec import load_scenario

pytestmark = pytest.mark.e2e

SCENARIO = scenario_path("mco_urban")
BATTERY_AGREEMENT_PP = 8.0
"""Largest |full - swarm| battery left per vehicle, percentage points. Measured on mco_urban at
seed 14: 0.2 to 1.5 pp (docs/swarm.md), but by compensating errors (the swarm engine drains more
per second, about 315 W against 294 W, and is airborne 13 to 40 s less); before its vehicles held
over home and came home low as the MAVSDK program does, it was 2 to 5 pp. The bound allows either
error alone: 40 s at 315 W is 3.5 Wh, 6 % of the smallest (4 Ah) pack."""


def _value(metrics: dict, name: str):
    return metrics[name]["value"]


def test_the_fleet_flies_the_mco_plan_and_the_swarm_engine_predicts_its_battery(swarmsitl_run):
    """Every companion succeeds and lands; each vehicle flew (battery below 100 %) its own role
    and task, one Master; the tasks together are the plan's waypoints (the plan rebuilt here from
    the run's world, args, fleet and seed); the swarm prediction's battery is within
    BATTERY_AGREEMENT_PP of the flight model's for every vehicle."""
    result = swarmsitl_run(SCENARIO)
    result.assert_companions_succeeded()
    assert result.exit_code == 0, result.output
    result.assert_landed_and_disarmed()
    report = result.report
    scenario = load_scenario(SCENARIO)
    n = scenario.spec.n_vehicles
    names = [f"vehicle{k + 1}" for k in range(n)]

    results = {name: json.loads((result.run_dir / name / "result.json").read_text())
               for name in names}  # fmt: skip
    for name in names:
        assert report["vehicles"][name]["companion"] == results[name], name
    roles = [_value(r, "role") for r in results.values()]
    assert roles.count("master") == 1, roles
    for name, r in results.items():
        battery = _value(r, "battery_remaining")
        assert 0.0 < battery < 100.0, (name, battery)
        assert _value(r, "distance_flown_m") > 0.5 * _value(r, "planned_path"), (name, r)

    # The plan every companion flew, rebuilt from the same inputs.
    role = scenario.spec.roles["mav"]
    params = params_from_mapping(McoParams, role.args)
    bidders = fleet_bidders(scenario.fleet_entries(), "mav", n)
    plan = cached_plan(str(result.run_dir / "world.yaml"), params, bidders, report["seed"])
    for k, name in enumerate(names):
        task = plan.task_of(k + 1)
        assert _value(results[name], "role") == str(task.role)
        assert _value(results[name], "sub_area") == task.sub_area
        assert _value(results[name], "task_waypoints") == len(task.waypoints_xy_m)
        assert _value(results[name], "plan_waypoints") == plan.waypoints
    flown = np.vstack([t.waypoints_xy_m for t in plan.tasks])
    assert len(flown) == plan.waypoints
    assert {tuple(p) for p in np.round(flown, 3)} == {
        tuple(p) for p in np.round(plan.grid.waypoints_xy_m, 3)
    }

    prediction = report["swarm_prediction"]
    assert prediction["complete"], prediction
    for name in names:
        v = prediction["vehicles"][name]
        full, swarm = v["battery_remaining_full"], v["battery_remaining_swarm"]
        assert isinstance(swarm, float) and 0.0 < swarm < 100.0, (name, v)
        assert abs(full - swarm) < BATTERY_AGREEMENT_PP, (name, v)
