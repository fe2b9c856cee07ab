"""The messaging network's processes in a run: its role nodes, the feed they read, the report.

``swarmsitl up --net``, ``swarmsitl net-demo`` and ``swarmsitl run`` (a scenario with a network)
start ``python -m companion.roles`` nodes with :func:`role_process`, feed the vehicles'
positions to the network with :func:`attach`, stop what still runs with
:func:`stop_processes` and write the network report with :func:`write_report`.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from rich.table import Table

from harness.net.plan import NetRun
from harness.net.report import energy_table, link_table
from harness.run.launch import console
from harness.sim.simulation import Simulation


def _json_safe(value: Any) -> Any:
    """NaN and infinities as None (JSON has neither)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def attach(net: NetRun, sim: Simulation) -> None:
    """Feed the vehicles' positions and rotor power to the network at the router's polls."""

    def feed(now_s: float, positions_enu_m: object) -> None:
        net.update(now_s, positions_enu_m, sim.world.rotor_power_w())

    sim.on_positions(feed)


def node_table(net: NetRun) -> Table:
    """Who is who: node, role, vehicle, where it listens, where others reach it."""
    table = Table(title=f"messaging network ({net.net_path})")
    for column in ("node", "role", "vehicle", "binds", "reached at (router)", "groups"):
        table.add_column(column, no_wrap=True)
    for node in net.nodes:
        table.add_row(
            node.node_id,
            node.role,
            "-" if node.vehicle is None else str(node.vehicle + 1),
            f"{node.address[0]}:{node.address[1]}",
            f"{net.plan.bind_addr}:{node.proxy_port}",
            ", ".join(node.groups) or "-",
        )
    return table


def role_process(
    net: NetRun,
    node_id: str,
    duration_s: float,
    speed: float,
    wall_origin_s: float,
    log_path: Path,
    extra: list[str] | None = None,
    clock_file: Path | None = None,
) -> subprocess.Popen:
    """Start ``python -m companion.roles`` as ``node_id`` (a real process, real UDP).

    ``clock_file``: the simulation clock (``SWARMSITL_CLOCK_FILE``), which the node's clock
    reads instead of scaling wall time (needed when the simulation is not paced).
    """
    env = os.environ | net.env(node_id)
    env |= {"SWARMSITL_SPEED": f"{speed:g}", "SWARMSITL_CLOCK_ORIGIN": repr(wall_origin_s)}
    if clock_file is not None:
        env["SWARMSITL_CLOCK_FILE"] = str(clock_file)
    cmd = [sys.executable, "-m", "companion.roles", "--duration-s", f"{duration_s:g}"]
    with log_path.open("w") as log:
        return subprocess.Popen(
            cmd + (extra or []), env=env, stdout=log, stderr=subprocess.STDOUT, text=True
        )


def stop_processes(procs: dict[str, subprocess.Popen], grace_s: float = 10.0) -> None:
    """SIGTERM what still runs (each writes its records), then kill after ``grace_s``."""
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
    deadline = time.monotonic() + grace_s
    for proc in procs.values():
        try:
            proc.wait(max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def write_report(
    net: NetRun,
    t1_s: float,
    path: Path,
    extra: dict[str, Any],
    traffic_s: float | None = None,
) -> dict[str, Any]:
    """Compute the run's network report over [0, t1_s], write it as JSON and print its tables.

    ``traffic_s``: the window the link metrics are averaged over (default: the whole run).
    """
    report = net.report(0.0, t1_s, traffic_s)
    report.update(extra)
    path.write_text(json.dumps(_json_safe(report), indent=1))
    console.print(link_table(report))
    console.print(energy_table(report))
    missing = report.get("nodes_without_records") or []
    if missing:
        console.print(
            f"[yellow]no message records from {', '.join(missing)}[/yellow] (a node writes "
            "them with AsyncNode.write_records / python -m companion.roles; link metrics above "
            "come from the link models and are complete)"
        )
    console.print(f"network report: {path}")
    return report


def role_output(log_path: Path, proc: subprocess.Popen) -> dict[str, Any]:
    """The JSON line a role prints at its end (the last one that parses), else what went wrong."""
    try:
        lines = log_path.read_text().strip().splitlines()
    except OSError:
        lines = []
    for line in reversed(lines):
        try:
            value = json.loads(line)
        except ValueError:
            continue
        if isinstance(value, dict):
            return value
    return {"error": lines[-1] if lines else "no output", "exit_code": proc.returncode}


def write_net_env(
    net: NetRun, path: Path, speed: float, wall_origin_s: float, clock_file: Path
) -> None:
    """``net.env`` of ``swarmsitl up --net``: what a user's node program sources, and say so."""
    path.write_text(
        f"# source this, then set SWARMSITL_NODE (one of: "
        f"{', '.join(n.node_id for n in net.nodes)})\n"
        f"export SWARMSITL_SPEED={speed:g}\nexport SWARMSITL_CLOCK_ORIGIN={wall_origin_s!r}\n"
        f"export SWARMSITL_CLOCK_FILE={clock_file}\n"
        f"export SWARMSITL_NET={net.net_path}\n"
        f"export SWARMSITL_NET_RECORDS={net.records_dir}\n"
    )
    env = f"SWARMSITL_SPEED={speed:g} SWARMSITL_CLOCK_ORIGIN={wall_origin_s!r}"
    console.print(
        f"companion programs: {env} SWARMSITL_NET={net.net_path} SWARMSITL_NODE=<node> "
        f"python your_program.py   (records: SWARMSITL_NET_RECORDS={net.records_dir})"
    )
