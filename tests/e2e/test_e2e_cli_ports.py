"""``swarmsitl up`` on UDP ports that are already taken exits non-zero and names the port."""

from __future__ import annotations

import socket
import subprocess

import pytest
from e2e_support import (
    REPO_ROOT,
    SPEED,
    RawLink,
    cli_command,
    cli_env,
    module_ports,
    require_free_udp,
    running_swarm,
)
from pymavlink.dialects.v20 import common as mavlink2

pytestmark = pytest.mark.e2e

PORTS = module_ports()


def run_up(out, vehicles: int, sdk: int, listen: int) -> subprocess.CompletedProcess:
    cmd = cli_command(
        "up", "--vehicles", vehicles, "--lockstep", "--max-speed", SPEED, "--sdk-port", sdk,
        "--listen-port", listen, "--gcs-port", 0, "--out", out, "--duration", 5, "--no-camera",
    )  # fmt: skip
    return subprocess.run(
        cmd, cwd=REPO_ROOT, env=cli_env(), capture_output=True, text=True, timeout=120
    )


def test_second_up_on_the_same_ports_fails_naming_the_port(tmp_path):
    """A second ``up`` on the ports of a running one exits non-zero, naming the listen port.

    The first instance keeps running and answering (checked with a raw HEARTBEAT read), and its
    own teardown still exits 0 with a readable tlog.
    """
    with running_swarm(1, PORTS, tmp_path / "first") as swarm:
        second = run_up(tmp_path / "second", 1, PORTS.sdk, PORTS.listen)
        output = second.stdout + second.stderr
        assert second.returncode != 0, output
        assert str(PORTS.listen) in output, output
        assert "Traceback" not in output, output
        link = RawLink(PORTS.listen, swarm.clock)
        try:
            # Any valid MAVLink frame makes the vehicle stream to us too.
            link.send(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
            assert len(link.heartbeats(2)) == 2
        finally:
            link.close()


def test_up_fails_when_a_later_vehicles_port_is_taken(tmp_path):
    """With vehicle 1's listen port held by another socket, ``up --vehicles 3`` names that port."""
    sdk, listen = PORTS.sdk + 1, PORTS.listen + 1  # block ports not used by the test above
    taken = listen + 1
    require_free_udp([listen, listen + 2])
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.bind(("127.0.0.1", taken))
    try:
        result = run_up(tmp_path / "run", 3, sdk, listen)
    finally:
        holder.close()
    output = result.stdout + result.stderr
    assert result.returncode != 0, output
    assert str(taken) in output, output
    assert "Traceback" not in output, output
    # The endpoint opened before the failure was closed again: its port is free.
    require_free_udp([listen])
