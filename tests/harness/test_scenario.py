"""Scenario files: every mistake is caught before anything starts, naming file, line and field."""

import sys
import textwrap
from pathlib import Path

import pytest

from harness.scenarios.spec import DEFAULT_PARAMS, ScenarioError, load_scenario, parse_scenario

pytestmark = pytest.mark.sockets

GOOD = """\
name: survey
seed: 3
duration_s: 60
world: example:offshore
launch_area: helideck
fleet:
  - role: survey
    count: 2
  - role: spare
    airframe: x500
roles:
  survey:
    module: companion.scripts.coverage
    args: {altitude_m: 25}
    params: {MPC_XY_CRUISE: 6}
  spare: {}
checks:
  landed_and_disarmed: true
  metrics:
    fleet.spills_seen: [1, null]
"""


def write(tmp_path: Path, text: str, name: str = "s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_a_good_scenario_resolves_its_fleet_and_world(tmp_path):
    scenario = load_scenario(write(tmp_path, GOOD))
    assert scenario.spec.n_vehicles == 3
    assert [(v.index, v.group.role, v.role_index, v.role_count) for v in scenario.vehicles] == [
        (0, "survey", 0, 2),
        (1, "survey", 1, 2),
        (2, "spare", 0, 1),
    ]
    assert scenario.world is not None and scenario.world.kind == "offshore"
    assert scenario.program("survey") == [sys.executable, "-m", "companion.scripts.coverage"]
    assert scenario.program("spare") is None
    params = scenario.params_of(scenario.vehicles[0])
    assert params == DEFAULT_PARAMS | {"MPC_XY_CRUISE": 6.0}
    assert scenario.spec.checks.metrics == {"fleet.spills_seen": (1.0, None)}


def test_world_file_relative_to_the_scenario_and_its_round_trip(tmp_path):
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "tiny.yaml").write_text("kind: taskmap\nseed: 4\ntask_count: 3\n")
    text = GOOD.replace("example:offshore", "worlds/tiny.yaml").replace(
        "launch_area: helideck\n", ""
    )
    scenario = load_scenario(write(tmp_path, text))
    assert scenario.world.kind == "taskmap"
    import worlds

    again = worlds.build(worlds.parse_world(scenario.world_yaml()))
    assert again == scenario.world


def test_config_hash_follows_the_file_and_the_world(tmp_path):
    a = load_scenario(write(tmp_path, GOOD, "a.yaml")).config_hash()
    assert a == load_scenario(write(tmp_path, GOOD, "b.yaml")).config_hash()
    assert (
        a
        != load_scenario(
            write(tmp_path, GOOD.replace("seed: 3", "seed: 4"), "c.yaml")
        ).config_hash()
    )


def test_reseed_world_builds_a_new_map_per_seed():
    base = GOOD.replace("seed: 3", "seed: 11") + "reseed_world: true\n"
    a = parse_scenario(base)
    b = parse_scenario(base.replace("seed: 11", "seed: 12"))
    assert a.world.seed == 11 and b.world.seed == 12
    assert a.world.targets != b.world.targets


@pytest.mark.parametrize(
    ("change", "where"),
    [
        (("    count: 2\n", "    count: 2\n    colour: red\n"), ":9: fleet.0.colour: unknown key"),
        (("duration_s: 60\n", ""), "duration_s: missing field"),
        (("duration_s: 60", "duration_s: soon"), ":3: duration_s:"),
        (("    count: 2\n", "    count: 0\n"), ":8: fleet.0.count:"),
        (("  spare: {}\n", ""), "roles: no entry for spare"),
        (("example:offshore", "example:moon"), ":4: world: kind: no example 'moon'"),
        (("example:offshore", "nowhere.yaml"), ":4: world: no such world file"),
        (("launch_area: helideck", "launch_area: roof"), ":5: launch_area: no launch area 'roof'"),
        (("airframe: x500", "airframe: x9000"), ":10: fleet.1.airframe:"),
        (("MPC_XY_CRUISE: 6", "MPC_XY_CRUSE: 6"), "roles.survey.params.MPC_XY_CRUSE: unknown"),
        (
            ("  spare: {}\n", "  spare: {}\nlinks: {onboard: smoke}\n"),
            "links.onboard: unknown link",
        ),
        (("seed: 3\n", "seed: 3\nseed: 4\n"), ":3: seed: duplicate key"),
        (
            ("    module: companion.scripts.coverage\n", "    module: a\n    script: b.py\n"),
            "one of module, script or command",
        ),
    ],
)
def test_mistakes_name_file_line_and_field(tmp_path, change, where):
    text = GOOD.replace(*change)
    assert text != GOOD
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, text))
    assert where in str(info.value)
    assert str(tmp_path / "s.yaml") in str(info.value)


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (("launch_area: heli", "launch_aera: heli"), ":5: launch_aera: unknown key; did you mean "),
        (("    count: 2\n", "    cont: 2\n"), ":8: fleet.0.cont: unknown key; did you mean count?"),
        (
            ("    module:", "    modul:"),
            ":13: roles.survey.modul: unknown key; did you mean module?",
        ),
        (
            ("  landed_and", "  landed_adn"),
            "checks.landed_adn_disarmed: unknown key; did you mean ",
        ),
        (("checks:", "sensor: {}\nchecks:"), ":17: sensor: unknown key; did you mean sensors?"),
        (
            ("checks:", "links: {onbord: x}\nchecks:"),
            "links.onbord: unknown key; did you mean onboard?",
        ),
        (("  - role: spare", "  - role: spar"), "no entry for spar (a role"),
        (("MPC_XY_CRUISE: 6", "MPC_XY_CRUSE: 6"), "parameter; did you mean MPC_XY_CRUISE"),
        (("MPC_XY_CRUISE: 6", "QQQQ: 6"), "parameter (the autopilot's are in autopilot_emu/"),
        (("{altitude_m: 25}", "{altitde_m: 25}"), ":14: roles.survey.args.altitde_m: unknown arg"),
    ],
)
def test_a_misspelt_name_gets_the_close_known_names(tmp_path, change, says):
    text = GOOD.replace(*change)
    assert text != GOOD
    with pytest.raises(ScenarioError) as info:
        load_scenario(write(tmp_path, text))
    assert says in str(info.value)
    meant = {"launch_aera": "launch_area", "landed_adn": "landed_and_disarmed", "spar": "spare"}
    meant |= {"altitde_m": "altitude_m"}
    for typo, name in meant.items():
        if typo in change[1]:
            assert f"did you mean {name}" in str(info.value)


def test_a_world_mistake_names_the_world_file(tmp_path):
    (tmp_path / "bad.yaml").write_text("kind: offshore\nseed: 1\nspill_cont: 3\n")
    with pytest.raises(ScenarioError, match=r"bad.yaml:3: spill_cont: unknown key"):
        load_scenario(write(tmp_path, GOOD.replace("example:offshore", "bad.yaml")))


def test_not_a_mapping_and_not_yaml(tmp_path):
    with pytest.raises(ScenarioError, match=r"s\.yaml:1: a scenario file is a mapping"):
        load_scenario(write(tmp_path, "- just a list\n"))
    with pytest.raises(ScenarioError, match="not valid YAML"):
        load_scenario(write(tmp_path, "name: [unclosed\n"))
    with pytest.raises(ScenarioError, match="cannot read scenario file"):
        load_scenario(tmp_path / "absent.yaml")


def test_script_paths_resolve_against_the_scenario(tmp_path):
    (tmp_path / "mine.py").write_text("print('hi')\n")
    text = GOOD.replace("    module: companion.scripts.coverage\n", "    script: mine.py\n")
    scenario = load_scenario(write(tmp_path, text))
    assert scenario.program("survey") == [sys.executable, str(tmp_path / "mine.py")]
    with pytest.raises(ScenarioError, match=r"roles\.survey\.script: no such file"):
        load_scenario(write(tmp_path, text.replace("mine.py", "theirs.py")))


def test_each_vehicle_gets_its_roles_autopilot_parameters(tmp_path):
    """The runner's SimulationConfig carries DEFAULT_PARAMS + the role's, per vehicle."""
    from harness.scenarios.runner import RunOptions, ScenarioRun
    from harness.sim.simulation import Simulation

    text = GOOD.replace("  spare: {}\n", "  spare: {params: {NAV_DLL_ACT: 0}}\n")
    run = ScenarioRun(load_scenario(write(tmp_path, text)), RunOptions(tmp_path / "run"))
    cfg = run._simulation_config()
    assert [p["NAV_DLL_ACT"] for p in cfg.vehicle_params] == [2, 2, 0]
    assert [p.get("MPC_XY_CRUISE") for p in cfg.vehicle_params] == [6, 6, None]
    cfg = type(cfg)(**{**cfg.__dict__, "mavlink": False, "out_dir": None, "router": None})
    with Simulation(cfg) as sim:
        assert [p.get("NAV_DLL_ACT") for p in sim.fleet.params] == [2, 2, 0]
        assert sim.fleet.params[0].get("MPC_XY_CRUISE") == 6.0
