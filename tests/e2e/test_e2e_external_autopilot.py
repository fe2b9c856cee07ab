"""Classic MAVSDK flies a vehicle whose autopilot is another process, across PX4's TCP protocol.

``swarmsitl up --autopilot external`` (the simulator, listening on TCP) and ``swarmsitl
autopilot`` (our emulator in PX4 SITL's place, connecting to it) are separate processes; the
companion (MAVSDK-Python's classic API with its ``mavsdk_server``) talks to the autopilot's UDP
link as to PX4 SITL. Paced and lockstep.
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from e2e_support import (
    REPO_ROOT,
    SPEED,
    cli_command,
    cli_env,
    module_ports,
    require_free_udp,
    run_client,
)

from harness.run.ports import free_port_block

pytestmark = pytest.mark.e2e

PORTS = module_ports()
HIL_PORT = free_port_block(2)
"""TCP port of the simulator's vehicle 0 (+1 in the second test; PX4 would use 4560), from the
suite's allocator."""
READY = "Press Ctrl-C to stop."


@contextmanager
def _process(cmd: list[str], log: Path) -> Iterator[subprocess.Popen]:
    with log.open("w") as fh:
        proc = subprocess.Popen(
            cmd, stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, cwd=REPO_ROOT,
            env=cli_env(), start_new_session=True,
        )  # fmt: skip
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@contextmanager
def _external_flight(
    tmp: Path, *mode: str
) -> Iterator[tuple[subprocess.Popen, subprocess.Popen, Path, Path]]:
    """``up --autopilot external`` and ``autopilot --instance 0``, both running."""
    require_free_udp([PORTS.sdk, PORTS.listen])
    up_log, ap_log = tmp / "up.log", tmp / "autopilot.log"
    up = cli_command(
        "up", "--autopilot", "external", "--hil-port", HIL_PORT, *mode, "--no-camera",
        "--out", tmp / "run", "--gcs-port", 0, "--duration", 600,
    )  # fmt: skip
    ap = cli_command(
        "autopilot", "--instance", 0, "--connect", f"tcp:127.0.0.1:{HIL_PORT}",
        "--sdk-port", PORTS.sdk, "--listen-port", PORTS.listen, "--gcs-port", 0,
        "--out", tmp / "autopilot",
    )  # fmt: skip
    with _process(up, up_log) as sim, _process(ap, ap_log) as autopilot:
        deadline = time.monotonic() + 120
        while READY not in up_log.read_text(errors="replace"):
            assert sim.poll() is None, up_log.read_text()
            assert autopilot.poll() is None, ap_log.read_text()
            assert time.monotonic() < deadline, up_log.read_text() + ap_log.read_text()
            time.sleep(0.1)
        yield sim, autopilot, up_log, ap_log


@pytest.mark.parametrize("mode", [("--speed", SPEED), ("--lockstep",)], ids=["paced", "lockstep"])
def test_classic_mavsdk_takes_off_with_an_external_autopilot(tmp_path, mode):
    """Arm, take off to 5 m: the flight goes simulator -> TCP -> autopilot -> UDP -> MAVSDK."""
    with _external_flight(tmp_path, *mode) as (sim, autopilot, up_log, ap_log):
        result = run_client(
            "classic_takeoff.py",
            ["--url", PORTS.url(), "--grpc-port", str(PORTS.grpc), "--alt", "5"],
            tmp_path / "client",
            clock=tmp_path / "run" / "clock",
            grpc_port=PORTS.grpc,
        )
        assert result.ok, result.describe() + up_log.read_text() + ap_log.read_text()
        assert result.data["mav_sys_id"] == 1
        assert result.data["rel_alt_reached_m"] >= 4.5
        # Ctrl-C on the simulator: the autopilot sees the connection close and ends by itself.
        sim.send_signal(signal.SIGINT)
        assert sim.wait(timeout=60) == 0, up_log.read_text()
        assert autopilot.wait(timeout=30) == 0, ap_log.read_text()
    assert "simulator closed" in ap_log.read_text()
    assert (tmp_path / "autopilot" / "vehicle1.tlog").stat().st_size > 0
    assert (tmp_path / "run" / "truth.csv").stat().st_size > 0


def test_a_raw_pymavlink_script_is_the_autopilot(tmp_path):
    """examples/px4_protocol_hover.py (pymavlink only, PX4's greeting and replies) climbs to 3 m
    and hovers level: the TCP protocol is PX4's, not a private one of ours."""
    port = HIL_PORT + 1
    up = cli_command(
        "up", "--autopilot", "external", "--hil-port", port, "--lockstep", "--no-camera",
        "--out", tmp_path / "run", "--gcs-port", 0, "--duration", 600,
    )  # fmt: skip
    with _process(up, tmp_path / "up.log") as sim:
        script = REPO_ROOT / "examples" / "px4_protocol_hover.py"
        done = subprocess.run(
            [sys.executable, str(script), "--connect", f"tcp:127.0.0.1:{port}", "--alt", "3"],
            capture_output=True, text=True, timeout=300, cwd=REPO_ROOT, env=cli_env(),
        )  # fmt: skip
        assert done.returncode == 0, done.stderr + (tmp_path / "up.log").read_text()
        result = json.loads(done.stdout.strip().splitlines()[-1])
        sim.send_signal(signal.SIGINT)
        assert sim.wait(timeout=60) == 0
    assert result["HIL_SENSOR"] >= 5000  # 20 simulated seconds at 250 Hz, each answered
    assert result["HIL_STATE_QUATERNION"] >= 3900  # the 5 ms PX4 asks for
    assert 2.7 < result["final_m"] < 3.3
    assert result["tilt_deg"] < 5.0
    assert "1 disconnect(s)" in (tmp_path / "up.log").read_text()  # the script hung up at 20 s
