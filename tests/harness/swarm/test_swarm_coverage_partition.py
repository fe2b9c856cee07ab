"""Swarm fidelity: the coverage role flies seed 004's k-means regions instead of its strips."""

from __future__ import annotations

import yaml

from harness.scenarios import scenario_path
from harness.scenarios.spec import parse_scenario
from harness.swarm.run import run_swarm


def test_four_vehicles_sweep_kmeans_regions_and_land() -> None:
    """``partition: kmeans`` in the role's args: every companion succeeds and covers something."""
    spec = yaml.safe_load(scenario_path("swarm_coverage").read_text())
    spec["fleet"][0]["count"] = 4
    spec["duration_s"] = 120
    spec["roles"]["survey"]["args"]["area_enu_m"] = [0, 10, 300, 310]
    spec["roles"]["survey"]["args"]["partition"] = "kmeans"
    scenario = parse_scenario(
        yaml.safe_dump(spec), "swarm.yaml", scenario_path("swarm_coverage").parent
    )
    report = run_swarm(scenario, seed=0)
    assert report["passed"], report["checks"]
    assert report["fleet"]["companions"]["coverage_fraction"]["value"] > 0.0
    for name, vehicle in report["vehicles"].items():
        assert vehicle["companion"]["coverage_fraction"]["value"] > 0.0, name
