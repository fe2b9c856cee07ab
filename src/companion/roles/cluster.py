"""Who coordinates whom: fog clusters from the network's groups (seed 000, Sec. 3.1).

A fog node coordinates the edge nodes that share a group with it (seed 000: at most 9 edge
agents per fog). Pure functions of the :class:`companion.net.NetConfig`.
"""

from __future__ import annotations

from companion.net import NetConfig

MAX_EDGES_PER_FOG = 9
"""Seed 000, Sec. 3.1: "each fog <= 9 edge agents"."""


def clusters(config: NetConfig) -> dict[str, list[str]]:
    """Each fog node's edge members (edges sharing one of its groups), in config order."""
    out: dict[str, list[str]] = {}
    for fog_id, fog in config.nodes.items():
        if fog.role != "fog":
            continue
        groups = set(fog.groups)
        out[fog_id] = [
            node_id
            for node_id, spec in config.nodes.items()
            if spec.role == "edge" and groups.intersection(spec.groups)
        ]
        if len(out[fog_id]) > MAX_EDGES_PER_FOG:
            raise ValueError(
                f"nodes.{fog_id}.groups: {len(out[fog_id])} edge members, seed 000 allows "
                f"{MAX_EDGES_PER_FOG} per fog"
            )
    return out


def coordinator_of(config: NetConfig, edge_id: str) -> str | None:
    """The fog node coordinating ``edge_id`` (the first whose cluster has it), else None."""
    for fog_id, members in clusters(config).items():
        if edge_id in members:
            return fog_id
    return None


def nodes_with_role(config: NetConfig, role: str) -> list[str]:
    """Ids of the nodes of ``role``, in config order."""
    return [node_id for node_id, spec in config.nodes.items() if spec.role == role]
