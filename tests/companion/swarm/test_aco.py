"""Seed 001's ACO swarm role at swarm fidelity: plan, fly, avoid, land at the mirrored targets."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from companion.scenario_env import ScenarioEnv
from companion.scripts.aco_swarm import run_metrics
from companion.swarm.aco import (
    AcoRoleParams,
    Peer,
    aco_layout,
    arena,
    mirror_target,
    plan_route,
    zones,
)
from harness.scenarios.spec import ScenarioError, parse_scenario
from harness.swarm.run import run_swarm

WORLD = {
    "kind": "arena_aco",
    "seed": 1,
    "size_m": [300, 300],
    "static_obstacle_count": 4,
    "moving_obstacle_count": 3,
    "zone_radius_m": 20,
}


def _spec(args: dict, count: int = 5, spacing: float = 6.0) -> dict:
    return {
        "name": "aco-small",
        "fidelity": "swarm",
        "seed": 2,
        "duration_s": 120,
        "world": WORLD,
        "launch_area": "start",
        "spacing_m": spacing,
        "fleet": [{"role": "aco", "count": count, "airframe": "x500"}],
        "roles": {"aco": {"module": "companion.scripts.aco_swarm", "args": args}},
        "sensors": {"cameras": False, "rangefinders": False},
        "swarm": {"step_hz": 20, "decision_hz": 10},
        "checks": {"landed_and_disarmed": True, "companions_succeeded": True, "max_collisions": 0},
    }


ARGS = {"roadmap_nodes": 60, "altitude_band_m": 0}
ARRIVE_SLACK_M = 1.0
"""Arrival tolerance (``companion.swarm.aco.ARRIVE_M``): the flown distance may be this short."""


@pytest.mark.parametrize(("planner", "option"), [("aco", 1), ("astar", 1), ("aco", 2)])
def test_five_vehicles_reach_their_targets_without_collisions(
    planner: str, option: int, tmp_path: Path
) -> None:
    """Every vehicle reaches and lands at its target (option 1: mirrored; option 2: translated),
    no contact, run metrics all present and in range (PQ <= 100, MC 100, FT = makespan / 60 s,
    FC only for option 2)."""
    args = ARGS | {"planner": planner, "option": option}
    scenario = parse_scenario(yaml.safe_dump(_spec(args)), "a.yaml", tmp_path)
    report = run_swarm(scenario, run_dir=tmp_path / "run")
    assert report["passed"], report["checks"]
    assert report["fleet"]["collisions"]["value"] == 0
    rows = [
        {k: v["value"] for k, v in veh["companion"].items()} for veh in report["vehicles"].values()
    ]
    assert all(r["reached"] and r["phase"] == "done" for r in rows), rows
    for r in rows:
        assert r["total_dist_m"] >= r["min_dist_m"] - ARRIVE_SLACK_M
        assert r["path_length_m"] >= r["min_dist_m"] - 1e-6
    env = ScenarioEnv(
        mavlink_url="swarm://", grpc_port=0, vehicle=1, vehicles=5, role="aco", role_index=0,
        role_count=5, seed=2, out_dir=tmp_path, world=tmp_path / "run" / "world.yaml",
        params=args,
    )  # fmt: skip
    m = run_metrics(env, report)
    assert m["mc"] == (100.0, "%")
    assert 50.0 < m["pq"][0] <= 100.0
    makespan = max(r["arrived_s"] for r in rows) - min(r["mission_start_s"] for r in rows)
    assert m["ft"][0] == pytest.approx(makespan / 60.0, abs=1e-3)
    assert m["cf"][0] is not None
    if option == 1:
        assert m["fc"][0] is None
    else:  # the formation held to a fraction of the 0.1 m allowance on average
        assert 0.0 <= m["fc"][0] < 100.0
    assert report["fleet"]["run"]["pq"]["value"] == pytest.approx(m["pq"][0])


def test_mirror_target_keeps_pairwise_distances() -> None:
    """The targets are the starts mirrored (east offset negated): every pairwise distance kept."""
    rng = np.random.default_rng(0)
    homes = np.c_[rng.uniform(-130, -110, (6, 2)), np.zeros(6)]
    s, g = np.array([-120.0, 0, 0]), np.array([120.0, 0, 0])
    targets = np.array([mirror_target(h, s, g) for h in homes])
    for i in range(6):
        assert math.dist(targets[i][:2], g[:2]) == pytest.approx(math.dist(homes[i][:2], s[:2]))
        for j in range(6):
            assert math.dist(targets[i], targets[j]) == pytest.approx(math.dist(homes[i], homes[j]))


def test_params_validation_names_the_field() -> None:
    """Bad values fail with the field's name; threshold <= 0 is an error."""
    with pytest.raises(ValueError, match="threshold_m"):
        AcoRoleParams(threshold_m=0.0)
    with pytest.raises(ValueError, match="option"):
        AcoRoleParams(option=3)
    with pytest.raises(ValueError, match="planner"):
        AcoRoleParams(planner="rrt")
    with pytest.raises(ValueError, match="points"):
        AcoRoleParams(points=0)


def test_a_fleet_the_start_zone_cannot_hold_fails_at_load(tmp_path: Path) -> None:
    """60 vehicles 2 m apart do not fit a 20 m start zone: the scenario fails when it loads."""
    with pytest.raises(ScenarioError, match="start zone"):
        parse_scenario(yaml.safe_dump(_spec(ARGS, count=600)), "a.yaml", tmp_path)


def _world(tmp_path: Path):
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(WORLD))
    return arena(str(path))


def test_option_2_layout_and_plan_are_the_formation_translated(tmp_path: Path) -> None:
    """Option 2: each target is its start moved by the zones' centres' offset, and every
    vehicle's path is the one shared plan moved by its start's offset (the same for any vehicle
    generator: the plan draws from the run's seed only, and leaves the vehicle's own untouched)."""
    world = _world(tmp_path)
    start_zone, goal_zone = zones(world)
    params = AcoRoleParams(option=2, roadmap_nodes=60, iterations=10, altitude_band_m=0)
    c = np.array(start_zone.center_enu_m, float)
    homes = [c + np.array([3.0, -4.0, 0.0]), c + np.array([-6.0, 2.0, 0.0])]
    shift = np.array(goal_zone.center_enu_m, float) - c
    plans = []
    for k, home in enumerate(homes):
        lay = aco_layout(world, params, home, f"vehicle {k + 1}")
        assert lay.start_enu_m == pytest.approx(home + np.array([0, 0, params.altitude_m]))
        assert lay.target_enu_m == pytest.approx(lay.start_enu_m + shift)
        rng = np.random.default_rng([7, k])
        before = rng.bit_generator.state
        plans.append(plan_route(world, params, lay, seed=7, rng=rng))
        assert rng.bit_generator.state == before
    a, b = (p.waypoints_enu_m for p in plans)
    assert b - a == pytest.approx(np.broadcast_to(homes[1] - homes[0], a.shape))
    assert plans[0].length_m == pytest.approx(plans[1].length_m)


def test_option_1_plans_from_the_vehicles_own_generator(tmp_path: Path) -> None:
    """Option 1: the target is the mirror point, and the plan draws from the vehicle's generator
    (from start to target), so two generators may give two paths between the same ends."""
    world = _world(tmp_path)
    start_zone, goal_zone = zones(world)
    params = AcoRoleParams(option=1, roadmap_nodes=60, iterations=10, altitude_band_m=0)
    home = np.array(start_zone.center_enu_m, float) + np.array([3.0, -4.0, 0.0])
    lay = aco_layout(world, params, home, "vehicle 1")
    mirrored = mirror_target(home, start_zone.center_enu_m, goal_zone.center_enu_m)
    assert lay.target_enu_m == pytest.approx(mirrored + np.array([0, 0, params.altitude_m]))
    rng = np.random.default_rng([7, 1])
    before = rng.bit_generator.state
    plan = plan_route(world, params, lay, seed=7, rng=rng)
    assert rng.bit_generator.state != before
    assert plan.waypoints_enu_m[0] == pytest.approx(lay.start_enu_m)
    assert plan.waypoints_enu_m[-1] == pytest.approx(lay.target_enu_m)


def test_a_home_outside_the_start_zone_is_named(tmp_path: Path) -> None:
    world = _world(tmp_path)
    start_zone, _ = zones(world)
    far = np.array(start_zone.center_enu_m, float) + np.array([start_zone.radius_m + 1, 0, 0])
    with pytest.raises(ValueError, match=r"vehicle 4 starts at .* outside the start zone"):
        aco_layout(world, AcoRoleParams(), far, "vehicle 4")


def test_a_broadcast_reads_back_as_the_peer_it_describes() -> None:
    """``Peer.from_body`` of a message body: its fields, and its position extrapolated (never
    backwards in time)."""
    body = {"k": 2, "t": 4.0, "prio": 3, "s": [1, 2, 15], "p": [10.0, 0.0, 15.0], "v": [2, 0, 0]}
    peer = Peer.from_body(body)
    assert (peer.index, peer.priority, peer.time_s) == (2, 3, 4.0)
    assert peer.at(5.5) == pytest.approx([13.0, 0.0, 15.0])
    assert peer.at(3.0) == pytest.approx([10.0, 0.0, 15.0])
