"""docs/companions.md's own companion program and its scenario, as written, fly `swarmsitl run`.

The section "A companion of your own" shows a MAVSDK-Python program (the ```python block whose
first line is ``# square.py:``) and the scenario that flies it (the ```yaml block whose first
line is ``# square.yaml:``). This test takes both from the page, writes them side by side and
runs the scenario in lockstep through the project's pytest plugin: an example that stopped
flying, or drifted from what the page says it does, fails here.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.e2e

DOC = Path(__file__).resolve().parents[2] / "docs" / "companions.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```[ \t]*$", re.S | re.M)


def doc_block(language: str, first_line: str) -> str:
    """The one fenced ``language`` block of the page whose first line starts with ``first_line``."""
    found = [
        body
        for lang, body in FENCE.findall(DOC.read_text())
        if lang == language and body.startswith(first_line)
    ]
    assert len(found) == 1, f"{DOC}: {len(found)} ```{language} blocks start {first_line!r}"
    return found[0]


def test_the_companion_of_companions_md_flies_its_square_and_the_run_passes(
    swarmsitl_run, tmp_path
):
    program = doc_block("python", "# square.py:")
    scenario_text = doc_block("yaml", "# square.yaml:")
    scenario = yaml.safe_load(scenario_text)
    assert [g.get("count", 1) for g in scenario["fleet"]] == [1], "the page shows one vehicle"
    (role,) = scenario["roles"].values()
    assert role["script"] == "square.py", "the scenario names the program beside it"
    (tmp_path / "square.py").write_text(program)
    path = tmp_path / "square.yaml"
    path.write_text(scenario_text)

    result = swarmsitl_run(path)  # lockstep, free ports

    result.assert_passed()
    assert result.exit_code == 0, result.output
    report = result.report
    assert report["complete"] and report["stop_reason"] == "done", report["stop_reason"]
    assert report["companions"]["vehicle1"]["exit_code"] == 0
    for check in ("companions_succeeded", "landed_and_disarmed", "no_failsafe"):
        assert report["checks"][check]["ok"], (check, report["checks"][check])
    result.assert_landed_and_disarmed()
    result.assert_no_failsafe()
    assert report["vehicles"]["vehicle1"]["companion"]["corners_reached"]["value"] == 4
    # the square the page describes: side_m north, east, south, west at altitude_m, from the
    # vehicle's start
    side, altitude = role["args"]["side_m"], role["args"]["altitude_m"]
    east, north, up = json.loads((result.run_dir / "manifest.json").read_text())["spawn_enu_m"][0]
    corners = [(0, side), (side, side), (side, 0), (0, 0)]
    # The program accepts a corner within 1 m of its *estimated* position, horizontally, and
    # turns (or lands) at once; so the true track is checked horizontally, with 0.5 m for the
    # estimator, and the height separately while it flies the square.
    result.assert_waypoints_reached(0, [[east + e, north + n] for e, n in corners], tolerance_m=1.5)
    track = result.log.vehicle(0).track
    t_first, t_last = (
        track.time_s[
            np.flatnonzero(np.hypot(*(track.enu_m[:, :2] - [east + e, north + n]).T) < 1.5)[0]
        ]
        for e, n in (corners[0], corners[-2])
    )
    flying = (track.time_s >= t_first) & (track.time_s <= t_last)
    height = track.enu_m[flying, 2] - up
    assert abs(np.median(height) - altitude) < 0.5, (np.median(height), altitude)
