"""Seed 000's edge-fog-cloud messaging through the link models, with real processes.

``swarmsitl net-demo``: three vehicles whose companions (``python -m companion.roles``, one
process each) take off over MAVLink and exchange status, images, summaries and pings through the
UDP router, plus the cloud process; the report must show what happened. ``swarmsitl up --net``:
users' own companion programs (here ``companion.scripts.net_ping``) reach each other and the
cloud through the router with nothing but ``SWARMSITL_NET`` / ``SWARMSITL_NODE``. Windows are in
simulated time; no timing is asserted.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest
from e2e_support import (
    REPO_ROOT,
    SPEED,
    cli_command,
    cli_env,
    module_ports,
    require_free_udp,
    wait_sim,
)

from harness.run.ports import free_port_block

pytestmark = pytest.mark.e2e

PORTS = module_ports()


def test_net_demo_flies_messages_and_reports_links_and_energy(tmp_path):
    """Edges, fog and cloud exchange their traffic; per-class metrics and energy are reported."""
    net, proxy = free_port_block(4), free_port_block(4)  # nodes' ports, the router's ports
    net_ports = [net + k for k in range(4)] + [proxy + k for k in range(4)]
    require_free_udp([PORTS.sdk + i for i in range(3)] + [PORTS.listen + i for i in range(3)])
    require_free_udp(net_ports)
    out = tmp_path / "run"
    cmd = cli_command(
        "net-demo", "--duration", 12, "--speed", SPEED, "--out", out,
        "--sdk-port", PORTS.sdk, "--listen-port", PORTS.listen,
        "--net-port", net, "--proxy-port", proxy,
    )  # fmt: skip
    result = subprocess.run(
        cmd, cwd=REPO_ROOT, env=cli_env(), capture_output=True, text=True, timeout=400
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    report = json.loads((out / "net_report.json").read_text())
    assert report["messaging_s"] == pytest.approx(12.0, abs=0.01)
    classes = report["link_classes"]
    assert set(classes) == {"edge-edge", "edge-fog", "fog-cloud"}
    for row in classes.values():
        assert row["datagrams_submitted"] > 0
        assert row["latency_ms"]["mean"] > 0
        assert row["availability_pct"] == pytest.approx(100.0 - row["loss_pct"])
    # LTE to the cloud is slower than WiFi between UAVs.
    assert classes["fog-cloud"]["latency_ms"]["p50"] > classes["edge-fog"]["latency_ms"]["p50"]
    # Images are data, pings and joins are control: edge-fog is mostly data.
    assert classes["edge-fog"]["messages"]["overhead_pct"] < 10.0
    assert classes["edge-edge"]["messages"]["overhead_pct"] == pytest.approx(100.0)
    assert report["nodes_without_records"] == []
    roles = report["roles"]
    assert {roles[n]["flight"] for n in ("edge1", "edge2", "fog1")} == {"landed"}
    assert roles["fog1"]["counts"]["images"] > 0
    assert roles["cloud"]["counts"]["summaries"] > 0
    energy = report["energy"]["nodes"]
    for node in ("edge1", "edge2", "fog1"):
        assert energy[node]["propulsion_source"] == "flight_model"
        assert energy[node]["components_j"]["propulsion"] > 100.0 * report["messaging_s"]
    assert energy["cloud"]["components_j"]["cloud"] == pytest.approx(65.0 * report["sim_time_s"])
    assert {"T_data", "T_report", "T_conn"} <= set(report["energy"]["tasks"])
    assert (out / "vehicle1.tlog").stat().st_size > 0


def test_up_with_net_lets_any_companion_program_reach_the_others(tmp_path):
    """Two companions (net_ping) and the cloud that ``up --net`` starts ping each other."""
    net, proxy = free_port_block(3), free_port_block(3)  # nodes' ports, the router's ports
    net_ports = [net + k for k in range(3)] + [proxy + k for k in range(3)]
    require_free_udp([PORTS.sdk, PORTS.sdk + 1, PORTS.listen, PORTS.listen + 1, *net_ports])
    out = tmp_path / "run"
    cmd = cli_command(
        "up", "--vehicles", 2, "--net", "edge,fog", "--lockstep", "--max-speed", SPEED,
        "--duration", 20,
        "--out", out, "--sdk-port", PORTS.sdk, "--listen-port", PORTS.listen, "--gcs-port", 0,
        "--no-camera", "--net-port", net, "--net-proxy-port", proxy,
    )  # fmt: skip
    log_path = tmp_path / "up.log"
    with log_path.open("w") as log:
        up = subprocess.Popen(
            cmd, cwd=REPO_ROOT, env=cli_env(), stdout=log, stderr=subprocess.STDOUT, text=True
        )
    try:
        deadline = time.monotonic() + 90
        while not (out / "net.env").exists():
            assert up.poll() is None and time.monotonic() < deadline, log_path.read_text()
            time.sleep(0.2)
        env = os.environ | {
            "SWARMSITL_NET": str(out / "net.yaml"),
            "SWARMSITL_SPEED": str(SPEED),
            "SWARMSITL_CLOCK_FILE": str(out / "clock"),  # the pings wait in simulated time
        }
        pings = {
            node: subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "companion.scripts.net_ping",
                    "--count",
                    "3",
                    "--records",
                    str(out / "net" / f"{node}.json"),
                ],
                env=env | {"SWARMSITL_NODE": node},
                stdout=subprocess.PIPE,
                text=True,
            )
            for node in ("edge1", "fog1")
        }
        wait_sim(
            lambda: all(p.poll() is not None for p in pings.values()), 20, out / "clock",
            "the pings' end",
        )  # fmt: skip
        outputs = {node: p.communicate()[0] for node, p in pings.items()}
        for node, proc in pings.items():
            assert proc.returncode == 0, outputs[node]
            assert (
                "SUMMARY" in outputs[node] and "timeout" not in outputs[node].split("SUMMARY")[-1]
            )
        wait_sim(lambda: up.poll() is not None, 30, out / "clock", "the end of the 20 s run")
    finally:
        if up.poll() is None:
            up.kill()
            up.wait()
    assert up.returncode == 0, log_path.read_text()[-3000:]
    report = json.loads((out / "net_report.json").read_text())
    assert report["link_classes"]["edge-fog"]["datagrams_delivered"] >= 6  # 3 pings + 3 pongs
    assert report["link_classes"]["fog-cloud"]["datagrams_submitted"] > 0
    assert report["link_classes"]["edge-cloud"]["datagrams_submitted"] > 0
