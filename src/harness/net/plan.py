"""The messaging network of a run: who is who, where they listen, and the router between them.

Each vehicle's companion is a node (``edge1``, ``fog1``, ... by role), and the cloud is one more
(``cloud``, a process on the host, no vehicle). A node binds ``node_base + k`` on the host; the
router stands for it on ``proxy_base + k``. The run's ``net.yaml`` (``companion.net``'s format)
gives every node its address and routes every node *through the router*, so a companion program
reads ``SWARMSITL_NET`` and ``SWARMSITL_NODE`` exactly as it would on a Pi (where the file has no
routes) and its datagrams cross the link models of ``sitl.links`` in simulation time.

Fog clusters (seed 000, Sec. 3.1): the edges are dealt to the fog nodes in turn, each fog and
its edges sharing the group ``cluster<j>``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from harness.net.report import net_report, task_intervals
from harness.sim.link_models import links_config
from sitl.devices.link_router import LinkRouter, RouterNode
from sitl.links.config import LinksConfig
from sitl.links.network import LinkNetwork
from sitl.power.energy import EnergyLedger

VEHICLE_ROLES = ("edge", "fog")
"""Roles a vehicle's companion may take (the cloud is a host process)."""

CLOUD_ID = "cloud"


@dataclass(frozen=True)
class NetNode:
    """One node of the run's network."""

    node_id: str
    role: str
    vehicle: int | None
    """0-based vehicle index whose companion this node is; None: the cloud."""
    address: tuple[str, int]
    """Where the node binds and receives."""
    proxy_port: int
    """The router's port standing for this node (others send here)."""
    groups: tuple[str, ...] = ()


@dataclass(frozen=True)
class NetPlan:
    """The roles of the vehicles' companions and the ports of the network."""

    roles: tuple[str, ...]
    """Role of each vehicle's companion, in vehicle order (``edge`` or ``fog``)."""
    cloud: bool = True
    """Whether the network has a cloud node."""
    bind_addr: str = "127.0.0.1"
    node_base: int = 47000
    """UDP port of the first node (the cloud if any, then the vehicles in order)."""
    proxy_base: int = 47500
    """UDP port of the router standing for the first node."""
    links: LinksConfig | None = None
    """The link presets and classes (``harness.sim.link_models.links_config``, a scenario's
    ``Scenario.links_config()``); None: the shipped presets."""

    def __post_init__(self) -> None:
        if not self.roles:
            raise ValueError("roles: give one role per vehicle")
        for k, role in enumerate(self.roles):
            if role not in VEHICLE_ROLES:
                raise ValueError(
                    f"roles[{k}]: {role!r} is not a vehicle role; expected one of {VEHICLE_ROLES}"
                )
        count = len(self.roles) + int(self.cloud)
        for name in ("node_base", "proxy_base"):
            base = getattr(self, name)
            if not 1024 <= base <= 65535 - count:
                raise ValueError(f"{name}: {base} leaves no room for {count} ports below 65536")
        low, high = sorted((self.node_base, self.proxy_base))
        if high < low + count:
            raise ValueError(
                f"node_base {self.node_base} and proxy_base {self.proxy_base} overlap for "
                f"{count} nodes"
            )

    def nodes(self) -> list[NetNode]:
        """Every node: the cloud first (if any), then the vehicles' companions in order."""
        fogs = [i for i, role in enumerate(self.roles) if role == "fog"]
        cluster_of_fog = {i: f"cluster{j + 1}" for j, i in enumerate(fogs)}
        edges = [i for i, role in enumerate(self.roles) if role == "edge"]
        out: list[NetNode] = []
        k = 0
        if self.cloud:
            out.append(
                NetNode(CLOUD_ID, "cloud", None, (self.bind_addr, self.node_base), self.proxy_base)
            )
            k = 1
        counters = dict.fromkeys(VEHICLE_ROLES, 0)
        for i, role in enumerate(self.roles):
            counters[role] += 1
            if role == "fog":
                groups = (cluster_of_fog[i],)
            elif fogs:
                groups = (cluster_of_fog[fogs[edges.index(i) % len(fogs)]],)
            else:
                groups = ()
            out.append(
                NetNode(
                    f"{role}{counters[role]}",
                    role,
                    i,
                    (self.bind_addr, self.node_base + k),
                    self.proxy_base + k,
                    groups,
                )
            )
            k += 1
        return out

    def net_file(self) -> dict[str, Any]:
        """The ``net.yaml`` content (``companion.net`` format) with routes through the router."""
        nodes = {}
        routes = {}
        for node in self.nodes():
            spec: dict[str, Any] = {"role": node.role, "address": _address(node.address)}
            if node.groups:
                spec["groups"] = list(node.groups)
            nodes[node.node_id] = spec
            routes[node.node_id] = _address((self.bind_addr, node.proxy_port))
        return {"nodes": nodes, "routes": routes}


def _address(address: tuple[str, int]) -> str:
    return f"{address[0]}:{address[1]}"


def parse_roles(spec: str, n_vehicles: int) -> tuple[str, ...]:
    """``edge,edge,fog`` (one per vehicle) or one role for all; ValueError naming ``--net``."""
    roles = tuple(part.strip() for part in spec.split(",") if part.strip())
    if len(roles) == 1:
        roles = roles * n_vehicles
    if len(roles) != n_vehicles:
        raise ValueError(
            f"--net: {len(roles)} roles for {n_vehicles} vehicles; give one per vehicle or one "
            "for all"
        )
    for role in roles:
        if role not in VEHICLE_ROLES:
            raise ValueError(f"--net: unknown role {role!r}; expected one of {VEHICLE_ROLES}")
    return roles


class NetRun:
    """The network of one run: link models, router, the vehicles' positions, energy, records.

    Args:
        plan: roles and ports.
        seed: the run's seed (the link models draw from generators derived from it).
        out_dir: run directory: ``net.yaml`` is written there, the nodes' records go to
            ``net/<node>.json``.
    """

    def __init__(self, plan: NetPlan, seed: int, out_dir: Path) -> None:
        self.plan = plan
        self.nodes = plan.nodes()
        self.network = LinkNetwork(plan.links or links_config(), seed)
        for node in self.nodes:
            self.network.add_node(node.node_id, node.role)
        self.router = LinkRouter(
            self.network.submit,
            [RouterNode(n.node_id, n.role, n.address, n.proxy_port) for n in self.nodes],
            plan.bind_addr,
        )
        self.ledger = EnergyLedger()
        for node in self.nodes:
            self.ledger.add_node(node.node_id, node.role)
        self._vehicle_nodes = [n for n in self.nodes if n.vehicle is not None]
        self._vehicle_index = np.array([n.vehicle for n in self._vehicle_nodes], dtype=int)
        out_dir = out_dir.absolute()  # handed to role processes (SWARMSITL_NET, records)
        out_dir.mkdir(parents=True, exist_ok=True)
        self.net_path = out_dir / "net.yaml"
        self.net_path.write_text(json.dumps(plan.net_file(), indent=1))  # JSON is YAML
        self.records_dir = out_dir / "net"
        self.records_dir.mkdir(exist_ok=True)

    def update(self, now_s: float, positions_enu_m: np.ndarray, rotor_power_w: np.ndarray) -> None:
        """Tell the network where the vehicles are and the ledger what their rotors draw."""
        for node in self._vehicle_nodes:
            position = positions_enu_m[node.vehicle]
            if np.all(np.isfinite(position)):  # a diverged vehicle keeps its last position
                self.network.set_position(node.node_id, position)
        if self._vehicle_nodes:
            self.ledger.record_propulsion_fleet(
                [n.node_id for n in self._vehicle_nodes],
                now_s,
                np.asarray(rotor_power_w)[self._vehicle_index],
            )

    def env(self, node_id: str) -> dict[str, str]:
        """Environment of a companion process running as ``node_id`` in this run."""
        return {
            "SWARMSITL_NET": str(self.net_path),
            "SWARMSITL_NODE": node_id,
            "SWARMSITL_NET_RECORDS": str(self.records_dir),
        }

    def node_records(self) -> dict[str, dict]:
        """The records the nodes wrote (``net/<node>.json``); unreadable ones are skipped."""
        out = {}
        for node in self.nodes:
            path = self.records_dir / f"{node.node_id}.json"
            try:
                out[node.node_id] = json.loads(path.read_text())
            except (OSError, ValueError):
                continue
        return out

    def report(self, t0_s: float, t1_s: float, traffic_s: float | None = None) -> dict[str, Any]:
        """Link metrics per class, the nodes' message records and energy over ``[t0_s, t1_s]``.

        ``traffic_s``: the window the link metrics (throughput) are averaged over, when the
        traffic ran for less than the whole run (``net-demo``: the messaging phase, not the
        landing after it); default ``t1_s - t0_s``.
        """
        duration = max(traffic_s if traffic_s is not None else t1_s - t0_s, 1e-9)
        records = self.node_records()
        self.ledger.set_airtimes(self.network.airtime_s_by_node())
        energy = self.ledger.report(t0_s, t1_s, tasks=task_intervals(records, t0_s, t1_s))
        report = net_report(self.network.records(duration), records, energy)
        stats = self.router.stats
        report["router"] = {
            "unknown_senders": dict(stats.unknown_senders),
            "pairs": {
                f"{src}->{dst}": {
                    "received": pair.received,
                    "forwarded": pair.forwarded,
                    "dropped": dict(pair.dropped),
                    "send_errors": pair.send_errors,
                }
                for (src, dst), pair in sorted(stats.pairs.items())
            },
        }
        report["nodes_without_records"] = sorted(
            n.node_id for n in self.nodes if n.node_id not in records
        )
        return report
