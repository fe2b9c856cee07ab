"""What a node sent and received, per peer and link class, for seed 000's network metrics.

Seed 000 (ARCog-NET) reports per link class: latency (send -> receive delay), packet loss
("ratio of sent and received packets"), throughput (from packet sizes), availability and
communication overhead (control bytes / all bytes). A node alone knows what it sent and what
it received; loss needs both ends, so the harness joins the records of every node (A's
``sent`` to B against B's ``received`` from A).

One-way latency samples are ``receiver clock - sender's sent_s``: valid when both clocks
are the same (the harness's simulation time); on separate machines only with synchronised
clocks (PTP/NTP; see docs/messaging.md).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

from companion.net.envelope import CATEGORIES


@dataclass(slots=True)
class Traffic:
    """A count of datagrams and their bytes."""

    messages: int = 0
    """Datagrams."""
    bytes: int = 0
    """Encoded envelope bytes (UDP payload), bytes."""


@dataclass(slots=True)
class TaskRecord:
    """One interval a node spent on a named task (energy = power integrated over it)."""

    name: str
    """Task name."""
    start_s: float
    """Node clock at the start, s."""
    end_s: float
    """Node clock at the end, s."""


def _by_category() -> dict[str, Traffic]:
    return {c: Traffic() for c in CATEGORIES}


@dataclass(slots=True)
class PeerStats:
    """Traffic between this node and one peer."""

    peer: str
    """Peer node id."""
    link_class: str
    """Link class of the pair, e.g. "edge-fog"."""
    sent: dict[str, Traffic] = field(default_factory=_by_category)
    """Sent to the peer, per category (retransmissions included)."""
    received: dict[str, Traffic] = field(default_factory=_by_category)
    """Received from the peer, per category (duplicates included)."""
    latency_s: dict[str, list[float]] = field(default_factory=lambda: {c: [] for c in CATEGORIES})
    """One-way latency samples of received datagrams, per category, s."""
    rtt_s: list[float] = field(default_factory=list)
    """Round-trip times of this node's answered requests to the peer, s."""
    retries: int = 0
    """Request retransmissions to the peer."""
    timeouts: int = 0
    """Requests to the peer that failed after their last retry."""


@dataclass
class NodeStats:
    """All records of one node."""

    node_id: str
    """This node's id."""
    role: str
    """This node's role."""
    peers: dict[str, PeerStats] = field(default_factory=dict)
    """Per peer id."""
    malformed: int = 0
    """Datagrams that were not valid envelopes (dropped)."""
    misaddressed: int = 0
    """Envelopes for another node, or from a node not in the configuration (dropped)."""
    late_replies: int = 0
    """Replies to no pending request: late, duplicate or unknown (dropped)."""
    duplicate_requests: int = 0
    """Requests seen before (answered from the reply cache, handler not run again)."""
    tasks: list[TaskRecord] = field(default_factory=list)
    """Task intervals, in the order they ended."""

    def peer(self, peer: str, link: str) -> PeerStats:
        """The record of ``peer`` (created on first use)."""
        record = self.peers.get(peer)
        if record is None:
            record = self.peers[peer] = PeerStats(peer, link)
        return record

    def link_classes(self) -> dict[str, dict[str, Any]]:
        """Peer records summed per link class."""
        out: dict[str, dict[str, Any]] = {}
        for record in self.peers.values():
            agg = out.setdefault(
                record.link_class,
                {
                    "sent": {c: {"messages": 0, "bytes": 0} for c in CATEGORIES},
                    "received": {c: {"messages": 0, "bytes": 0} for c in CATEGORIES},
                    "latency_s": {c: [] for c in CATEGORIES},
                    "rtt_s": [],
                    "retries": 0,
                    "timeouts": 0,
                },
            )
            for c in CATEGORIES:
                for way in ("sent", "received"):
                    traffic = getattr(record, way)[c]
                    agg[way][c]["messages"] += traffic.messages
                    agg[way][c]["bytes"] += traffic.bytes
                agg["latency_s"][c].extend(record.latency_s[c])
            agg["rtt_s"].extend(record.rtt_s)
            agg["retries"] += record.retries
            agg["timeouts"] += record.timeouts
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready records: per peer, per link class, counters and tasks."""
        return {
            "node_id": self.node_id,
            "role": self.role,
            "peers": {p: asdict(r) for p, r in self.peers.items()},
            "link_classes": self.link_classes(),
            "malformed": self.malformed,
            "misaddressed": self.misaddressed,
            "late_replies": self.late_replies,
            "duplicate_requests": self.duplicate_requests,
            "tasks": [asdict(t) for t in self.tasks],
        }
