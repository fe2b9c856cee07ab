"""``swarmsitl demo`` end to end: the README's first command, on free ports, in lockstep.

Three vehicles on the offshore world, three coverage companions (real MAVSDK-Python processes,
mavsdk_server, UDP, MJPEG camera streams). The run's checks (every companion exited 0, all landed
and disarmed, 2 m separation, 45 deg tilt, inside the world) must pass, and the cameras must have
seen spills where the world put them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.e2e


def test_the_demo_flies_the_offshore_scenario_and_counts_spills(tmp_path, swarmsitl_ports):
    ports = swarmsitl_ports
    out = tmp_path / "demo"
    cmd = [sys.executable, "-m", "harness.cli", "demo", "--out", str(out),
           "--sdk-port", str(ports.sdk), "--listen-port", str(ports.listen),
           "--grpc-port", str(ports.grpc), "--payload-port", str(ports.payload)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=1200, check=False,
                          env=os.environ | {"COLUMNS": "200"})  # fmt: skip
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    report = json.loads((out / "report.json").read_text())
    assert report["passed"] and report["complete"], output
    assert report["scenario"] == "offshore-demo" and len(report["vehicles"]) == 3
    fleet = report["fleet"]["companions"]
    # the distinct spills the cameras could have seen (the world's, under the recorded
    # footprints once present) and the ones the detector found: most of them, and only those
    could = set(fleet["spills_in_footprint_names"]["items"])
    seen = set(fleet["spills_seen_names"]["items"])
    assert len(could) >= 3, fleet
    assert len(seen & could) >= 0.6 * len(could), fleet
    assert len(seen - could) <= 1, fleet  # a frame and its pose are paired within ~1 m
    assert (out / "plots" / "map.png").is_file()
    assert len(list((out / "camera").glob("vehicle*_t*.png"))) >= 3
    from harness.flight_log import FlightLog

    log = FlightLog.load(out)
    for i in range(3):
        up = log.vehicle(i).track["up_m"]
        assert up[0] > 25.0 and up[-1] > 25.0  # started and ended on the rig's 30 m deck
