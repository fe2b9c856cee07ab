"""``swarmsitl run`` end to end through the project's own pytest plugin (``harness.pytest_plugin``).

Real processes: the runner, one MAVSDK-Python companion per vehicle (tests/harness/scenarios/
hop.py, written as a user would write one), mavsdk_server, UDP. Lockstep runs, so the outcomes
depend on simulated time only (not on the machine's load: these tests are not in the paced
group of tests/e2e); the fixtures pick free ports for each test.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import yaml
from gnss_drift import gnss_drift_m

pytestmark = pytest.mark.e2e

HERE = Path(__file__).parent / "scenarios"
HOP = HERE / "hop.yaml"


def scenario_variant(tmp_path: Path, name: str, **changes) -> Path:
    """A copy of hop.yaml beside hop.py with top-level keys changed."""
    spec = yaml.safe_load(HOP.read_text()) | changes
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    (tmp_path / "hop.py").write_text((HERE / "hop.py").read_text())
    return path


def test_a_scenario_flies_and_its_report_holds_the_flight(swarmsitl_run):
    result = swarmsitl_run(HOP)
    result.assert_passed()
    assert result.exit_code == 0, result.output
    report = result.report
    assert report["complete"] and report["stop_reason"] == "done"
    assert report["mode"] == "lockstep" and report["seed"] == 1
    manifest = json.loads((result.run_dir / "manifest.json").read_text())
    assert manifest["complete"] and manifest["n_vehicles"] == 2
    # The true track is judged: 1 m plus what the vehicle's GNSS error may drift over the run
    # (the companion flies 6 m north of home as its autopilot sees it; gnss_drift.py).
    tolerance_m = 1.0 + gnss_drift_m(report["sim_time_s"])
    for i, spawn in enumerate(manifest["spawn_enu_m"]):
        # hop.py climbs to 4 m, flies 6 m north of where it took off and lands there
        goal = [spawn[0], spawn[1] + 6.0, spawn[2] + 4.0]
        landed = [spawn[0], spawn[1] + 6.0, spawn[2]]
        result.assert_waypoints_reached(i, [goal, landed], tolerance_m=tolerance_m)
        assert report["vehicles"][f"vehicle{i + 1}"]["companion"]["flown_to_north_m"]["value"] == 6
    result.assert_landed_and_disarmed()
    result.assert_max_tilt(35.0)
    files = ("plots/map.png", "plots/errors.png", "plots/battery.png", "timeseries/vehicle1.csv",
             "world.yaml", "scenario.yaml", "vehicle1.tlog", "vehicle2/companion.log")  # fmt: skip
    for name in files:
        assert (result.run_dir / name).is_file(), name
    assert report["fleet"]["companions"]["flown_to_north_m"]["sum"] == 12


def test_a_crashed_companion_is_reported_its_vehicle_returns_the_other_flies_on(
    swarmsitl_run, tmp_path
):
    path = scenario_variant(
        tmp_path,
        "one_broken",
        duration_s=120,
        fleet=[{"role": "hop", "count": 1}, {"role": "broken", "count": 1}],
        roles={
            "hop": {"script": "hop.py", "args": {"altitude_m": 4, "offset_enu_m": [0, 6]}},
            "broken": {"script": "hop.py", "args": {"altitude_m": 4, "break_after": "takeoff"}},
        },
    )
    result = swarmsitl_run(path)
    assert result.exit_code == 1, result.output
    report = result.report
    broken = report["companions"]["vehicle2"]
    assert broken["exit_code"] not in (0, None)
    assert "deliberately broken after takeoff" in broken["traceback"]
    assert report["companions"]["vehicle1"]["exit_code"] == 0
    assert not report["checks"]["companions_succeeded"]["ok"]
    with pytest.raises(AssertionError, match="deliberately broken"):
        result.assert_passed()
    # vehicle 1 finished its hop; vehicle 2's autopilot lost its companion's heartbeats and
    # returned (NAV_DLL_ACT = 2, the scenario default) and landed by itself
    assert "companion" in report["vehicles"]["vehicle1"]
    texts = [
        t["text"] for t in report["fleet"]["failsafe_texts"]["texts"] if t["vehicle"] == "vehicle2"
    ]
    assert any("ground station lost" in t for t in texts), texts
    result.assert_landed_and_disarmed()


def test_ctrl_c_leaves_readable_tlogs_and_a_report_marked_incomplete(swarmsitl_ports, tmp_path):
    out = tmp_path / "run"
    ports = swarmsitl_ports
    cmd = [sys.executable, "-m", "harness.cli", "run", str(HOP), "--out", str(out),
           "--sdk-port", str(ports.sdk), "--listen-port", str(ports.listen),
           "--grpc-port", str(ports.grpc), "--payload-port", str(ports.payload)]  # fmt: skip
    with (tmp_path / "out.log").open("w") as log:
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                env=os.environ | {"COLUMNS": "200"})  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not (out / "vehicle1" / "result.json").exists() and not _took_off(out):
            assert proc.poll() is None, (tmp_path / "out.log").read_text()
            assert time.monotonic() < deadline, (tmp_path / "out.log").read_text()
            time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(60) == 130, (tmp_path / "out.log").read_text()
    finally:
        if proc.poll() is None:
            proc.kill()
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] is False and report["stop_reason"] == "interrupted"
    assert json.loads((out / "manifest.json").read_text())["complete"] is False
    from harness.report.flight_log import FlightLog

    log = FlightLog.load(out)
    assert log.end_s > 1.0 and not log.warnings, log.warnings
    assert any(v.status_texts for v in log.vehicles)


def _took_off(out: Path) -> bool:
    """Some vehicle armed (companion logs say so once MAVSDK armed it)."""
    truth = out / "truth.csv"
    if not truth.exists():
        return False
    lines = truth.read_text().splitlines()[1:]
    return any(line.split(",")[19] == "1" for line in lines if line.count(",") > 20)


def test_a_user_test_written_with_the_plugin_passes_and_fails_when_the_companion_breaks(
    pytester,
):
    """A user's test file names its scenarios relative to itself, as
    docs/testing_your_companion.md shows, and pytest runs from the project root above it."""
    tests_dir = pytester.mkdir("tests")
    scenario_variant(tests_dir, "good")
    scenario_variant(
        tests_dir, "broken",
        roles={"hop": {"script": "hop.py", "args": {"altitude_m": 4, "break_after": "takeoff"}}},
        duration_s=45,
    )  # fmt: skip
    (tests_dir / "test_my_companion.py").write_text(
        textwrap.dedent(
            """
            def test_good(swarmsitl_run):
                run = swarmsitl_run("good.yaml")
                run.assert_passed()
                run.assert_min_separation(2.0)

            def test_broken(swarmsitl_run):
                run = swarmsitl_run("broken.yaml")
                run.assert_passed()
            """
        )
    )
    outcome = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "no:randomly")
    outcome.assert_outcomes(passed=1, failed=1)
    text = outcome.stdout.str()
    assert "test_broken" in text and "deliberately broken after takeoff" in text


def test_a_lockstep_fleet_for_your_own_client(swarmsitl_fleet):
    fleet = swarmsitl_fleet(vehicles=1, world="example:city", lockstep=True)
    client = Path(__file__).parents[1] / "e2e" / "clients" / "classic_takeoff.py"
    client_log = fleet.run_dir.parent / "client.log"
    with client_log.open("w") as out:
        proc = subprocess.Popen(
            [sys.executable, str(client), "--url", fleet.url(0), "--grpc-port",
             str(fleet.grpc_port(0)), "--alt", "5"],
            stdout=out, stderr=subprocess.STDOUT, env=fleet.env,
        )  # fmt: skip
    try:  # a limit in simulated seconds: a slow machine makes the fleet slower, not the test fail
        fleet.wait_until(lambda: proc.poll() is not None, 600, "the client's end")
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
    assert proc.returncode == 0, client_log.read_text()
    log = fleet.stop()
    from harness.report.flight_checks import assert_reached_altitude

    assert_reached_altitude(log, 0, 4.5, relative_to_start=True)
    assert "lockstep" in fleet.output
