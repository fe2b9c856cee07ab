"""Seed 004's experiment: its cases, fleets and scenarios, bad input, and the CLI."""

from __future__ import annotations

import dataclasses

import pytest
import yaml
from typer.testing import CliRunner

import worlds
from companion.planning.mco.boustrophedon import boustrophedon_cell_count
from companion.planning.mco.plan import McoParams
from companion.planning.mco.role import workspace_of
from companion.planning.mco.workspace import build_grid
from harness.cli import app
from harness.experiments.seed004 import (
    CASES,
    ExperimentError,
    check_inputs,
    fleet_classes,
    make_config,
    scenario_text,
)
from harness.scenarios.spec import ScenarioError, parse_scenario
from harness.sweep.trial import Trial, build_scenario
from worlds.examples import world_path


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_each_workspace_has_the_papers_largest_fleet_as_boustrophedon_cells(case) -> None:
    """Sec. 5: the largest n flown in a workspace is its Boustrophedon cell count."""
    workspace, _ = workspace_of(worlds.build(worlds.load_world(world_path(case.world))))
    params = McoParams()
    grid = build_grid(workspace, params.camera, params.flight_altitude_m, (0.75, 0.75))
    assert boustrophedon_cell_count(grid, workspace) == case.max_n


@pytest.mark.parametrize("n", [2, 4, 5, 12, 17, 40])
def test_a_fleet_has_a_hub_and_relays_per_level_and_workers(n: int) -> None:
    kinds = fleet_classes(n)
    levels = n // 16 + 1
    assert len(kinds) == n
    assert kinds.count("hub") == min(levels, n)
    assert kinds.count("relay") == min(4 * levels, n - min(levels, n))
    assert fleet_classes(n) == kinds, "the same n, the same fleet"


def test_a_cases_scenario_is_valid_and_carries_the_fleet_file() -> None:
    cfg = make_config(quick=True)
    case = CASES[2]
    text = scenario_text(case, 5, cfg)
    values = (("roles.mav.args.planner", "kmeans"),)
    scenario = build_scenario(Trial("", "/x/seed004.py", text, values, 3))
    spec = scenario.spec
    assert spec.fidelity == "swarm" and spec.seed == 3
    assert spec.roles["mav"].args["planner"] == "kmeans"
    (group,) = spec.fleet
    assert group.count == 5 and len(group.battery_capacity_mah) == 5
    assert set(group.traits) == {"decision", "communication", "flight_time_s"}
    # R = a quarter of the workspace's diagonal (Sec. 5.2)
    data = yaml.safe_load(text)
    x0, y0, x1, y1 = scenario.world.boundary.bounds
    assert data["swarm"]["link_range_m"] == pytest.approx(
        ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5 / 4, abs=1e-3
    )


def test_a_case_that_cannot_be_planned_stops_the_experiment_before_it_runs() -> None:
    cfg = make_config(quick=True)
    bad = dataclasses.replace(cfg, cases=CASES[:1], n_values={"rejoya": (13,)})
    with pytest.raises(ExperimentError, match=r"rejoya, boustrophedon, n=13: .*12 cells"):
        check_inputs(bad)
    check_inputs(dataclasses.replace(bad, n_values={"rejoya": (12,)}))


def test_configs() -> None:
    quick, full = make_config(True), make_config(False)
    assert quick.n_values == {"rejoya": (6, 12), "urban": (5, 10), "naranjos": (3, 7)}
    assert full.n_values["rejoya"] == tuple(range(2, 13)) and len(full.seeds) == 10
    assert make_config(False, seeds=3).seeds == (0, 1, 2)
    with pytest.raises(ValueError, match="--seeds"):
        make_config(True, seeds=0)


def test_the_cli_names_the_experiments_and_has_an_example(tmp_path) -> None:
    result = CliRunner().invoke(app, ["experiment", "seed999", "--out", str(tmp_path)])
    assert result.exit_code == 2
    assert "seed004" in result.output
    help_text = CliRunner().invoke(app, ["experiment", "--help"]).output
    assert "Example:" in help_text and "seed004 --quick" in help_text


@pytest.mark.parametrize(
    ("count", "planner", "message"),
    [(8, "boustrophedon", "n: 8 vehicles exceed the 7 cells"), (1, "kmeans", "n: 1 vehicles")],
)
def test_an_mco_scenario_with_a_fleet_the_plan_cannot_serve_fails_when_it_loads(
    count: int, planner: str, message: str
) -> None:
    text = (
        "name: bad\nseed: 0\nduration_s: 100\nworld: example:mco_naranjos\n"
        f"fleet: [{{role: mav, count: {count}, airframe: x500}}]\n"
        f"roles: {{mav: {{module: companion.scripts.mco_plan, args: {{planner: {planner}}}}}}}\n"
    )
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(text, "bad.yaml")
