"""In-test fakes for node messaging: a manual clock and a lossy in-memory datagram port."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable

from companion.net import NetConfig, Node, PortTransport
from harness.run.ports import free_port_block

BASE = free_port_block(4)
"""Ports of the nodes below, from the suite's allocator (this xdist worker's own slice)."""

CONFIG = NetConfig.from_dict(
    {
        "nodes": {
            "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE}"},
            "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 1}", "groups": ["cluster1"]},
            "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 2}", "groups": ["cluster1"]},
            "edge2": {"role": "edge", "address": f"127.0.0.1:{BASE + 3}", "groups": ["cluster1"]},
        }
    }
)


class ManualClock:
    """Simulated time the test advances by hand."""

    def __init__(self) -> None:
        self.t_s = 0.0

    def __call__(self) -> float:
        return self.t_s


class FakePort:
    """Delivers datagrams instantly unless ``drop(src, dst, data, index)`` says to drop them."""

    def __init__(self, drop: Callable[[str, str, bytes, int], bool] | None = None) -> None:
        self.drop = drop or (lambda *_: False)
        self.queues: dict[str, list[bytes]] = defaultdict(list)
        self.sent: list[tuple[str, str, bytes]] = []

    def send(self, src: str, dst: str, data: bytes) -> None:
        index = len(self.sent)
        self.sent.append((src, dst, data))
        if not self.drop(src, dst, data, index):
            self.queues[dst].append(data)

    def receive(self, node_id: str) -> list[bytes]:
        out, self.queues[node_id] = self.queues[node_id], []
        return out


def make_nodes(port: FakePort, clock: ManualClock, *ids: str) -> dict[str, Node]:
    return {i: Node(i, CONFIG, PortTransport(port, i), clock) for i in ids}
