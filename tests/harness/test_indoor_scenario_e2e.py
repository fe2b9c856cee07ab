"""The shipped indoor scenario (GPS-denied plant, two vehicles on external vision) end to end.

``swarmsitl run`` through the pytest plugin's ``swarmsitl_run`` fixture (which picks free
ports): the simulation, one mocap bridge and one ``companion.scripts.indoor_search`` per vehicle,
with a 130 s duration instead of the shipped 180 s: each vehicle visits the room that fits.
Each companion plans its rooms from the simulated time left when it has connected, so the
duration keeps about 25 s in hand beyond one room each: a loaded machine (MAVSDK's server
slow to start) connects later in simulated time too and must still fit a room.
"""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from harness.scenarios import scenario_path

pytestmark = pytest.mark.e2e

DURATION_S = 130.0
"""Simulated seconds: take-off, the nearest room of each part, the way back, landing, margin."""


def test_indoor_search_flies_the_rooms_and_lands(swarmsitl_run, tmp_path: Path) -> None:
    spec = yaml.safe_load(scenario_path("indoor").read_text())
    spec["duration_s"] = DURATION_S
    spec["camera_samples"] = 1
    scenario = tmp_path / "indoor_short.yaml"
    scenario.write_text(yaml.safe_dump(spec, sort_keys=False))

    result = swarmsitl_run(scenario)

    result.assert_passed()
    fleet = result.report["fleet"]["companions"]
    assert fleet["rooms_visited"]["value"] >= 2  # each vehicle reached the room that fits
    assert fleet["distance_flown_m"]["value"] > 40.0
    if fleet["people_in_view"]["value"] > 0:  # the paths passed someone: the cameras saw them
        assert fleet["people_found"]["value"] > 0
