"""The edge-fog-cloud report: seed 000's link metrics per link class, and energy per node and task.

Three sources, each authoritative for what it measures:

- the link models (``LinkNetwork.records``, simulation time): datagrams and bytes offered and
  delivered, loss, availability (seed 000: 100 - loss), uptime, latency, throughput, airtime;
- the nodes' own records (``companion.net`` stats, one JSON file per node): application messages
  by category, from which the communication overhead follows (seed 000, Sec. 2: data sent for
  network commands and requests / all data sent; here: bytes of ``control`` messages, i.e.
  requests, replies and retransmissions, over all bytes the nodes sent on that class), request
  round trips, retries and timeouts, and the task intervals;
- the energy ledger (``sitl.power.energy``): energy per node, component and task.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from rich.table import Table


def overhead_by_class(node_records: Mapping[str, Mapping[str, Any]]) -> dict[str, dict]:
    """Bytes the nodes sent per link class and category, and the overhead share, %."""
    out: dict[str, dict] = {}
    for record in node_records.values():
        for peer in record.get("peers", {}).values():
            row = out.setdefault(
                peer["link_class"],
                {"data_bytes": 0, "control_bytes": 0, "retries": 0, "timeouts": 0, "rtt_s": []},
            )
            sent = peer.get("sent", {})
            row["data_bytes"] += int(sent.get("data", {}).get("bytes", 0))
            row["control_bytes"] += int(sent.get("control", {}).get("bytes", 0))
            row["retries"] += int(peer.get("retries", 0))
            row["timeouts"] += int(peer.get("timeouts", 0))
            row["rtt_s"].extend(float(x) for x in peer.get("rtt_s", []))
    for row in out.values():
        total = row["data_bytes"] + row["control_bytes"]
        row["overhead_pct"] = 100.0 * row["control_bytes"] / total if total else 0.0
        rtts = row.pop("rtt_s")
        row["requests_answered"] = len(rtts)
        row["rtt_mean_ms"] = 1e3 * sum(rtts) / len(rtts) if rtts else math.nan
    return out


def task_intervals(
    node_records: Mapping[str, Mapping[str, Any]], t0_s: float, t1_s: float
) -> list[tuple[str, str, float, float]]:
    """Every recorded task as (node_id, name, start_s, end_s), clipped to the report window.

    Companion clocks follow the simulation's under swarmsitl (``SWARMSITL_CLOCK_ORIGIN``), up
    to the pace the simulation kept; tasks outside the window are left out.
    """
    out = []
    for node_id, record in node_records.items():
        for task in record.get("tasks", []):
            start = max(float(task["start_s"]), t0_s)
            end = min(float(task["end_s"]), t1_s)
            if end >= start and start < t1_s:
                out.append((node_id, str(task["name"]), start, end))
    return out


def net_report(
    link_records: Mapping[str, Any],
    node_records: Mapping[str, Mapping[str, Any]],
    energy: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """One report: per link class the link metrics joined with the nodes' overhead; energy."""
    overhead = overhead_by_class(node_records)
    classes: dict[str, dict] = {}
    for name in sorted(set(link_records.get("classes", {})) | set(overhead)):
        classes[name] = {**link_records.get("classes", {}).get(name, {})}
        classes[name]["messages"] = overhead.get(name, {})
    return {
        "duration_s": link_records.get("duration_s"),
        "link_classes": classes,
        "directions": dict(link_records.get("directions", {})),
        "nodes": {
            node_id: {
                "role": record.get("role"),
                "malformed": record.get("malformed", 0),
                "misaddressed": record.get("misaddressed", 0),
                "late_replies": record.get("late_replies", 0),
                "send_errors": record.get("send_errors", 0),
            }
            for node_id, record in node_records.items()
        },
        "energy": dict(energy) if energy is not None else None,
    }


def _fmt(value: float, digits: int = 2) -> str:
    return (
        "-"
        if value is None or (isinstance(value, float) and math.isnan(value))
        else (f"{value:.{digits}f}")
    )


def _fmt_j(value: float) -> str:
    """Energies span 1e-4 J (a radio's airtime) to 1e5 J (propulsion): 3 significant digits."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def link_table(report: Mapping[str, Any]) -> Table:
    """Seed 000's link metrics per link class, as a terminal table."""
    table = Table(title="links (simulation time)")
    for column in (
        "class",
        "datagrams",
        "loss %",
        "availability %",
        "uptime %",
        "latency mean ms",
        "p95 ms",
        "throughput kbit/s",
        "overhead %",
    ):
        table.add_column(column, justify="left" if column == "class" else "right")
    for name, row in report["link_classes"].items():
        latency = row.get("latency_ms", {})
        table.add_row(
            name,
            str(row.get("datagrams_submitted", 0)),
            _fmt(row.get("loss_pct", math.nan)),
            _fmt(row.get("availability_pct", math.nan)),
            _fmt(row.get("uptime_pct", math.nan)),
            _fmt(latency.get("mean", math.nan)),
            _fmt(latency.get("p95", math.nan)),
            _fmt(row.get("throughput_bps", math.nan) / 1e3),
            _fmt(row.get("messages", {}).get("overhead_pct", math.nan), 1),
        )
    return table


def energy_table(report: Mapping[str, Any]) -> Table:
    """Energy per node and component, J, as a terminal table."""
    energy = report.get("energy") or {}
    table = Table(title="energy (J)")
    table.add_column("node")
    table.add_column("role")
    components = list(energy.get("components_j", {}))
    for name in (*components, "total", "mean W"):
        table.add_column(name, justify="right")
    for node_id, node in energy.get("nodes", {}).items():
        cells = [_fmt_j(node["components_j"].get(c, 0.0)) for c in components]
        table.add_row(
            node_id,
            node["role"],
            *cells,
            _fmt_j(node["total_j"]),
            _fmt(node["mean_power_w"], 1),
        )
    return table
