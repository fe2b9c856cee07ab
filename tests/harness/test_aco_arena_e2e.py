"""Seed 001's ACO swarm (option 2) on the full stack: ``swarmsitl run aco_arena.yaml``.

Real processes as a user runs them (the runner, one MAVSDK-Python companion
``companion.scripts.aco_swarm`` per vehicle with its mavsdk_server, the link router between their
messaging nodes, UDP), lockstep, free ports from the plugin's ``swarmsitl_ports``. Six Typhoons
plan the shared ACO path, leave together, fly it in Offboard in formation among towers and
drifting drums while avoiding (Alg. 2) and keeping their formation (Alg. 4) from the positions
they broadcast, and land at their targets. Every wait is the run's, in simulated time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from companion.role_params import params_from_mapping
from companion.swarm.aco import AcoRoleParams
from harness.scenarios import scenario_path
from harness.scenarios.spec import load_scenario

pytestmark = pytest.mark.e2e

SCENARIO = scenario_path("aco_arena")
SAMPLE_S = 0.5
"""Spacing of the truth samples the formation is checked at, simulated s."""


def _values(companion: dict) -> dict:
    return {name: entry["value"] for name, entry in companion.items()}


def _at(track, t: float) -> np.ndarray:
    """(3,) the true position at ``t`` (linear between samples), ENU m."""
    return np.array([np.interp(t, track.time_s, track.enu_m[:, a]) for a in range(3)])


def test_six_typhoons_fly_option_2_in_formation_reach_their_targets_and_land(swarmsitl_run):
    """The run passes its checks with no collision; every vehicle reached its target (the
    start translated by the zones' offset) and landed and disarmed; PQ, MC, FC, FT, AD and CF
    are in range; Alg. 4 ran on what the radio brought (every vehicle's AvgDistChange is a
    positive number below the threshold), and the true formation, from the truth tracks, held:
    between the common departure and the first arrival, each vehicle's median change of its
    distances to the others stays below the threshold."""
    result = swarmsitl_run(SCENARIO)  # lockstep, free ports
    result.assert_passed()
    report = result.report
    assert report["fleet"]["collisions"]["value"] == 0, report["fleet"]["collisions"]
    params = params_from_mapping(AcoRoleParams, load_scenario(SCENARIO).spec.roles["aco"].args)
    threshold, depart = params.threshold_m, params.depart_s

    vehicles = {name: _values(v["companion"]) for name, v in report["vehicles"].items()}
    assert len(vehicles) == 6
    for name, v in vehicles.items():
        assert v["reached"] and v["phase"] == "done", (name, v)
        assert v["option"] == 2
        assert depart <= v["mission_start_s"] < depart + 0.5, (name, v)
        assert v["arrived_s"] > v["mission_start_s"] + v["min_dist_m"] / params.speed_m_s
        assert v["total_dist_m"] >= v["min_dist_m"] - 1.0, (name, v)
        assert isinstance(v["divergences"], int) and v["divergences"] >= 0, (name, v)
        assert 0.0 < v["avg_dist_change_m"] < threshold, (name, v)
        result.assert_landed_and_disarmed(int(name.removeprefix("vehicle")) - 1)

    run = _values(report["fleet"]["run"])
    assert run["mc"] == 100.0 and run["reached"] == 6, run
    assert 50.0 < run["pq"] <= 100.0, run
    assert 0.0 < run["fc"] < 100.0, run
    changes = [v["avg_dist_change_m"] for v in vehicles.values()]
    assert run["fc"] == pytest.approx(100.0 * np.mean(changes) / threshold, abs=1e-3)
    makespan = max(v["arrived_s"] for v in vehicles.values()) - min(
        v["mission_start_s"] for v in vehicles.values()
    )
    assert run["ft"] == pytest.approx(makespan / 60.0, abs=1e-3)
    assert run["ad"] == pytest.approx(np.mean([v["divergences"] for v in vehicles.values()]))
    assert run["cf"] is not None and math.isfinite(run["cf"]), run

    tracks = [result.log.vehicle(k).track for k in range(6)]
    homes = np.array([t.enu_m[0] for t in tracks])
    reference = np.linalg.norm(homes[:, None] - homes[None], axis=-1)
    t0 = max(v["mission_start_s"] for v in vehicles.values())
    t1 = min(v["arrived_s"] for v in vehicles.values())
    for t in np.arange(t0, t1, SAMPLE_S):
        here = np.array([_at(tr, t) for tr in tracks])
        change = np.abs(np.linalg.norm(here[:, None] - here[None], axis=-1) - reference)
        np.fill_diagonal(change, np.nan)
        assert np.nanmedian(change, axis=1).max() < threshold, (t, np.round(change, 2))
