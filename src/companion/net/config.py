"""Who is in the network: node ids, roles, addresses, groups and send routes, from YAML.

The same file serves a real deployment (every node binds and is reached at its ``address``)
and the harness (``routes`` point senders at the link emulator's router instead)::

    nodes:
      cloud: {role: cloud, address: "127.0.0.1:47000"}
      fog1:  {role: fog,   address: "127.0.0.1:47001", groups: [cluster1]}
      edge1: {role: edge,  address: "127.0.0.1:47002", groups: [cluster1]}
    routes:            # optional: where to SEND to reach a node (default: its address)
      fog1: "127.0.0.1:48001"

Errors raise ``NetConfigError`` naming the field path (``nodes.edge1.address``).
"""

from __future__ import annotations

import functools
import ipaddress
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ROLES: tuple[str, ...] = ("edge", "fog", "cloud", "ground")
"""Node roles, in the order link classes are named (edge < fog < cloud < ground)."""
ENV_NET = "SWARMSITL_NET"
"""Environment variable: path of the network YAML."""
ENV_NODE = "SWARMSITL_NODE"
"""Environment variable: id of this node in that file."""

_HOSTNAME = re.compile(r"^[A-Za-z0-9]([A-Za-z0-9.-]{0,251}[A-Za-z0-9])?$")
_NODE_KEYS = frozenset({"role", "address", "groups"})


class NetConfigError(ValueError):
    """The network configuration is invalid; the message names the field path."""


Address = tuple[str, int]
"""(host, port) of a UDP endpoint."""


def parse_address(text: object, where: str) -> Address:
    """Parse ``"host:port"`` (IPv4 address or host name, port 1-65535)."""
    if not isinstance(text, str) or text.count(":") != 1:
        raise NetConfigError(f"{where}: expected 'host:port', got {text!r}")
    host, port_text = text.split(":")
    if not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise NetConfigError(f"{where}: port must be 1-65535, got {port_text!r}")
    try:
        ipaddress.IPv4Address(host)
    except ValueError:
        if not _HOSTNAME.match(host) or host.replace(".", "").isdigit():
            raise NetConfigError(f"{where}: bad host {host!r}") from None
    return host, int(port_text)


@functools.lru_cache(maxsize=64)
def link_class(role_a: str, role_b: str) -> str:
    """Name of the link class between two roles, e.g. ``("cloud", "edge") -> "edge-cloud"``.

    Cached: every datagram a node sends or receives is counted under its link class.
    """
    for role in (role_a, role_b):
        if role not in ROLES:
            raise ValueError(f"role: unknown role {role!r}, expected one of {ROLES}")
    low, high = sorted((role_a, role_b), key=ROLES.index)
    return f"{low}-{high}"


@dataclass(frozen=True, slots=True)
class NodeSpec:
    """One node of the network."""

    node_id: str
    """Unique id (the key under ``nodes``)."""
    role: str
    """edge, fog, cloud or ground."""
    address: Address
    """Where the node binds and receives (host, port)."""
    groups: tuple[str, ...] = ()
    """Names of the groups the node belongs to."""

    def __post_init__(self) -> None:
        if self.role not in ROLES:
            raise NetConfigError(
                f"nodes.{self.node_id}.role: unknown role {self.role!r}, expected one of {ROLES}"
            )


@dataclass(frozen=True)
class NetConfig:
    """The whole network: nodes by id and the optional send routes."""

    nodes: dict[str, NodeSpec]
    """Nodes by id."""
    routes: dict[str, Address] = field(default_factory=dict)
    """Where to send to reach a node, if not its address (the harness's link router)."""

    def __post_init__(self) -> None:
        seen: dict[Address, str] = {}
        for node_id, spec in self.nodes.items():
            if spec.address in seen:
                raise NetConfigError(
                    f"nodes.{node_id}.address: {spec.address[0]}:{spec.address[1]} is "
                    f"already the address of {seen[spec.address]}"
                )
            seen[spec.address] = node_id
        for node_id in self.routes:
            if node_id not in self.nodes:
                raise NetConfigError(f"routes.{node_id}: unknown node {node_id!r}")

    @classmethod
    def from_dict(cls, data: Any) -> NetConfig:
        """Build from the parsed YAML mapping."""
        if not isinstance(data, dict):
            raise NetConfigError("(top level): expected a mapping with 'nodes'")
        unknown = set(data) - {"nodes", "routes"}
        if unknown:
            raise NetConfigError(f"{sorted(unknown)[0]}: unknown key (expected nodes, routes)")
        nodes_data = data.get("nodes")
        if not isinstance(nodes_data, dict) or not nodes_data:
            raise NetConfigError("nodes: missing or empty (expected a mapping of node ids)")
        nodes = {str(k): _node_from_dict(str(k), v) for k, v in nodes_data.items()}
        routes_data = data.get("routes") or {}
        if not isinstance(routes_data, dict):
            raise NetConfigError("routes: expected a mapping of node id to 'host:port'")
        routes = {str(k): parse_address(v, f"routes.{k}") for k, v in routes_data.items()}
        return cls(nodes=nodes, routes=routes)

    @classmethod
    def load(cls, path: str | Path) -> NetConfig:
        """Load a network YAML file."""
        try:
            text = Path(path).read_text()
        except OSError as exc:
            raise NetConfigError(f"{path}: cannot read network file: {exc}") from exc
        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise NetConfigError(f"{path}: not valid YAML: {exc}") from exc
        return cls.from_dict(data)

    @classmethod
    def from_env(cls) -> tuple[NetConfig, str]:
        """Load the file named by ``SWARMSITL_NET``; return it and ``SWARMSITL_NODE``."""
        path = os.environ.get(ENV_NET)
        node_id = os.environ.get(ENV_NODE)
        if not path:
            raise NetConfigError(f"{ENV_NET}: not set (path of the network YAML)")
        if not node_id:
            raise NetConfigError(f"{ENV_NODE}: not set (this node's id)")
        config = cls.load(path)
        if node_id not in config.nodes:
            raise NetConfigError(f"{ENV_NODE}: node {node_id!r} is not in {path}")
        return config, node_id

    def send_address(self, node_id: str) -> Address:
        """Where to send datagrams for ``node_id``: its route if any, else its address."""
        return self.routes.get(node_id, self.nodes[node_id].address)

    def members(self, group: str) -> list[str]:
        """Ids of the nodes in ``group`` (in file order)."""
        return [n for n, spec in self.nodes.items() if group in spec.groups]

    @property
    def groups(self) -> set[str]:
        """Names of all groups."""
        return {g for spec in self.nodes.values() for g in spec.groups}


def _node_from_dict(node_id: str, data: Any) -> NodeSpec:
    where = f"nodes.{node_id}"
    if not isinstance(data, dict):
        raise NetConfigError(f"{where}: expected a mapping with role and address")
    unknown = set(data) - _NODE_KEYS
    if unknown:
        raise NetConfigError(f"{where}.{sorted(unknown)[0]}: unknown key")
    for key in ("role", "address"):
        if key not in data:
            raise NetConfigError(f"{where}.{key}: missing")
    groups = data.get("groups") or []
    if not isinstance(groups, list) or not all(isinstance(g, str) and g for g in groups):
        raise NetConfigError(f"{where}.groups: expected a list of group names")
    return NodeSpec(
        node_id=node_id,
        role=str(data["role"]),
        address=parse_address(data["address"], f"{where}.address"),
        groups=tuple(groups),
    )
