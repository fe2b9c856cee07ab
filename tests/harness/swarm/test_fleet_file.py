"""The fleet file's per-vehicle pack capacities and traits: validated, and handed on."""

from __future__ import annotations

from pathlib import Path

import pytest

from companion.scenario_env import ScenarioEnv
from harness.scenarios.spec import ScenarioError, parse_scenario

FLEET = """
name: fleet
duration_s: 10
fleet:
  - role: a
    count: 2
    battery_capacity_mah: [1000, 2500]
    traits: {decision: [0.2, 0.9], communication: 0.5}
  - role: b
    airframe: x500
roles: {a: {}, b: {}}
"""


def test_capacities_and_traits_are_per_vehicle_and_default_to_the_airframe():
    """A list gives each vehicle its value, one value the group; no capacity: the airframe's."""
    scenario = parse_scenario(FLEET)
    entries = scenario.fleet_entries()
    assert [e["battery_capacity_mah"] for e in entries] == [1000.0, 2500.0, 5000.0]
    assert [e["traits"] for e in entries] == [
        {"decision": 0.2, "communication": 0.5},
        {"decision": 0.9, "communication": 0.5},
        {},
    ]
    assert [(e["vehicle"], e["role"], e["role_index"]) for e in entries] == [
        (1, "a", 0),
        (2, "a", 1),
        (3, "b", 0),
    ]
    # the autopilot's capacity follows the pack's, only where the file sets one
    params = [scenario.params_of(v) for v in scenario.vehicles]
    assert [p.get("BAT1_CAPACITY") for p in params] == [1000.0, 2500.0, None]


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("battery_capacity_mah: [1000]", "battery_capacity_mah has 1 values for count 2"),
        ("battery_capacity_mah: 0", "battery_capacity_mah must be > 0"),
        ("battery_capacity_mah: [1000, -1]", "battery_capacity_mah must be > 0"),
        ("traits: {decision: [1, 2, 3]}", "traits.decision has 3 values for count 2"),
    ],
)
def test_a_bad_capacity_or_trait_names_the_field(line, message):
    text = FLEET.replace("battery_capacity_mah: [1000, 2500]", line).replace(
        "traits: {decision: [0.2, 0.9], communication: 0.5}", ""
    )
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text)


def test_the_runner_gives_the_world_the_capacities_and_the_companions_the_fleet(tmp_path):
    """Full fidelity: the World's packs and each companion's SWARMSITL_FLEET (no process runs)."""
    from harness.scenarios.runner import RunOptions, ScenarioRun
    from harness.scenarios.spec import load_scenario
    from sitl.world import World

    path = tmp_path / "fleet.yaml"
    path.write_text(FLEET)
    run = ScenarioRun(load_scenario(path), RunOptions(tmp_path / "run"))
    config = run._simulation_config()
    assert config.world_config().battery_capacity_mah == (1000.0, 2500.0, None)
    assert [p.get("BAT1_CAPACITY") for p in config.vehicle_params] == [1000.0, 2500.0, None]
    world = World(config.world_config())
    try:
        assert world.power_of(0).pack.capacity_mah.tolist() == [1000.0, 2500.0]
        assert world.power_of(2).pack.capacity_mah.tolist() == [5000.0]
    finally:
        world.close()
    env = ScenarioEnv(
        "swarm://", 0, 1, 3, "a", 0, 2, 0, Path("."), fleet=run.fleet_entries
    ).to_env()
    assert ScenarioEnv.from_env(env).fleet == run.fleet_entries
