"""Companions in lockstep, end to end: a frozen companion pauses the simulation.

Before the lockstep gate, freezing a hovering companion for 6 wall seconds let 27 simulated
seconds pass and fired the data-link-loss failsafe. Here a plain MAVSDK-Python program (it
imports nothing of swarmsitl, so it takes part only through its MAVLink traffic and its
process) is stopped with SIGSTOP while it hovers: the simulation must stand still until it
continues, and the flight must end without a failsafe.
"""

from __future__ import annotations

import json
import os
import signal
import struct
import subprocess
import time
from pathlib import Path

import pytest

from harness.pytest_plugin import _cli, _port_options
from harness.run.lockstep import LOCKSTEP
from harness.scenarios.runner import CHECK_EVERY_S

pytestmark = pytest.mark.e2e

SCENARIO = Path(__file__).parent / "scenarios" / "freeze_hover.yaml"
WATCHDOG_WALL_S = 300.0
"""A hung run fails the test after this long."""
FREEZE_WALL_S = 6.0
"""How long the companion stays stopped (the failsafe's 10 simulated s took 2 wall s before)."""
SETTLE_WALL_S = 1.0
"""Wall time given to the gate to notice the stop before the clock is read."""


def clock_s(run_dir: Path) -> float:
    """The simulation time the run publishes (``SWARMSITL_CLOCK_FILE``)."""
    return struct.unpack("<d", (run_dir / "clock").read_bytes()[:8])[0]


def wait_for(path: Path, proc: subprocess.Popen, log: Path) -> str:
    """The text of ``path`` once it has some (the run must still be going)."""
    deadline = time.monotonic() + WATCHDOG_WALL_S
    while not (path.exists() and path.read_text()):
        assert proc.poll() is None, log.read_text()
        assert time.monotonic() < deadline, log.read_text()
        time.sleep(0.05)
    return path.read_text()


@pytest.mark.parametrize("frozen", ["process group", "program only"])
def test_a_frozen_companion_pauses_the_simulation_and_keeps_its_link(
    tmp_path, swarmsitl_ports, frozen
):
    """Stopping the whole companion (program and its mavsdk_server) or only the Python program
    stops the simulated clock within the lockstep's bound; it stands still for as long as the
    companion does, then the flight lands without a failsafe. A held vehicle still sends
    HEARTBEAT once a wall second: a running mavsdk_server never times it out (before, one
    that did stopped its own heartbeats, and the held simulation waited for them)."""
    run_dir, log = tmp_path / "run", tmp_path / "run.log"
    ports = swarmsitl_ports
    args = ["run", SCENARIO, "--out", run_dir, *_port_options(ports), "--grpc-port", ports.grpc]
    args += ["--lockstep", "--timeout", WATCHDOG_WALL_S]
    with log.open("w") as out:
        proc = subprocess.Popen(_cli(*args), stdout=out, stderr=subprocess.STDOUT)
    try:
        pid = int(wait_for(run_dir / "vehicle1" / "hovering", proc, log))
        stop = (lambda s: os.killpg(pid, s)) if frozen == "process group" else (
            lambda s: os.kill(pid, s)
        )  # fmt: skip
        stop(signal.SIGSTOP)
        at_stop = clock_s(run_dir)
        time.sleep(SETTLE_WALL_S)
        paused = clock_s(run_dir)
        time.sleep(FREEZE_WALL_S - SETTLE_WALL_S)
        still = clock_s(run_dir)
        stop(signal.SIGCONT)
        (run_dir / "vehicle1" / "release").write_text("go")
        proc.wait(WATCHDOG_WALL_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    output = log.read_text()
    assert still == paused, f"the clock moved from {paused} to {still} s while frozen"
    if frozen == "process group":  # its mavsdk_server's PING echoes stopped with it
        assert paused - at_stop <= LOCKSTEP.lead_s + CHECK_EVERY_S + 1e-6, (at_stop, paused)
    report = json.loads((run_dir / "report.json").read_text())
    assert report["passed"] and report["complete"], (report.get("checks"), output)
    if frozen == "program only":  # its mavsdk_server ran on: the held vehicle kept beating
        server_log = (run_dir / "vehicle1" / "companion.log").read_text()
        assert "Heartbeats from system 1 timed out" not in server_log, server_log
    assert report["lockstep"]["held_wall_s"] >= FREEZE_WALL_S - SETTLE_WALL_S
