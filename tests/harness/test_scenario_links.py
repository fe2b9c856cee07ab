"""Inline link presets in a scenario: merged as a link file's, checked at load, used by the run."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from harness.scenarios.spec import ScenarioError, load_scenario, parse_scenario
from harness.swarm.run import run_swarm
from harness.sweep.spec import plan_sweep
from harness.sweep.trial import build_scenario

SCENARIO = """\
name: mesh
fidelity: swarm
duration_s: 20
spacing_m: 5
fleet:
  - role: hop
    count: 2
    node: edge
roles:
  hop: {module: inline_links_hop}
links:
  presets:
    mesh: {base: wifi, range_m: RANGE}
  classes:
    edge-edge: mesh
"""

PROGRAM = """
def swarm_program(env, vehicle, node):
    return Hop(vehicle)


class Hop:
    '''Up to 10 m at once, down after 10 s.'''

    error = None

    def __init__(self, vehicle):
        self.vehicle = vehicle
        self.landing = False

    @property
    def done(self):
        return self.landing and not self.vehicle.airborne

    def decide(self, now_s):
        if now_s == 0.0:
            self.vehicle.takeoff(10.0)
        elif now_s >= 10.0 and not self.landing:
            self.vehicle.land()
            self.landing = True

    def metrics(self):
        return {"neighbours": (len(self.vehicle.neighbours()), "count")}
"""


@pytest.fixture(autouse=True)
def hop_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "inline_links_hop.py").write_text(PROGRAM)
    monkeypatch.syspath_prepend(str(tmp_path))


def scenario_file(tmp_path: Path, range_m: object = 8.0, text: str = SCENARIO) -> Path:
    path = tmp_path / "mesh.yaml"
    path.write_text(text.replace("RANGE", str(range_m)))
    return path


def test_inline_presets_merge_over_the_shipped_ones_and_the_link_file(tmp_path):
    """Inline over file over shipped: the inline field wins, the file's others stay."""
    (tmp_path / "links.yaml").write_text(
        "presets:\n  mesh: {base: wifi, range_m: 50.0, rate_bps: 7000000.0}\n"
        "classes:\n  edge-fog: mesh\n"
    )
    text = SCENARIO.replace("links:\n", "links:\n  file: links.yaml\n")
    config = load_scenario(scenario_file(tmp_path, 8.0, text)).links_config()
    mesh = config.presets["mesh"]
    assert mesh.up.range_m == 8.0  # the scenario's
    assert mesh.up.rate_bps == 7e6  # the file's
    assert mesh.up.queue_bytes == config.presets["wifi"].up.queue_bytes  # the shipped base's
    assert config.classes["edge-edge"] == config.classes["edge-fog"] == "mesh"
    assert config.classes["fog-cloud"] == "lte"  # shipped
    plain = load_scenario(scenario_file(tmp_path, 8.0, text.split("links:")[0])).links_config()
    assert "mesh" not in plain.presets


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (("range_m: RANGE", "range_m: -5"), ":13: links.presets.mesh.range_m: must be"),
        (("edge-edge: mesh", "edge-edge: mesch"), ":15: links.classes.edge-edge: unknown preset"),
        (("base: wifi", "base: wiffi"), "links.presets.mesh.base: unknown preset 'wiffi'"),
    ],
)
def test_a_bad_inline_preset_fails_at_load_naming_its_field(tmp_path, change, says):
    path = scenario_file(tmp_path, 8.0, SCENARIO.replace(*change))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert says in str(info.value)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(("range_m", "linked"), [(8.0, True), (4.0, False)])
def test_the_swarm_radio_range_is_the_inline_edge_edge_range(tmp_path, range_m, linked):
    """Two vehicles 5 m apart: neighbours and links within an 8 m mesh, none within 4 m."""
    report = run_swarm(load_scenario(scenario_file(tmp_path, range_m)), seed=0)
    assert (report["fleet"]["links_per_agent_mean"]["value"] > 0) is linked
    assert (report["fleet"]["companions"]["neighbours"]["value"] == 2) is linked


def test_a_sweep_over_an_inline_preset_field_plans(tmp_path):
    scenario_file(tmp_path)
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text("scenario: mesh.yaml\ngrid:\n  links.presets.mesh.range_m: [4.0, 8.0]\n")
    plan = plan_sweep(sweep)
    ranges = [build_scenario(t).links_config().presets["mesh"].up.range_m for t in plan.trials]
    assert ranges == [4.0, 8.0]
    assert len({t.trial_id for t in plan.trials}) == 2
    bad = tmp_path / "bad.yaml"
    bad.write_text("scenario: mesh.yaml\ngrid:\n  links.presets.mesh.range_mm: [4.0]\n")
    with pytest.raises(ValueError, match="mesh has no 'range_mm'"):
        plan_sweep(bad)


def test_inline_links_alone_parse_without_a_file():
    text = textwrap.dedent(SCENARIO.replace("RANGE", "8.0"))
    config = parse_scenario(text).links_config()
    assert config.presets["mesh"].up.range_m == 8.0
    assert config.classes["edge-edge"] == "mesh"
