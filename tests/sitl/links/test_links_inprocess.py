"""The lockstep transport: held until the simulated arrival, delivered in arrival order."""

from __future__ import annotations

import pytest

from sitl.links.channel import DatagramTooLargeError, Drop
from sitl.links.config import LinksConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork


class _Clock:
    def __init__(self) -> None:
        self.now_s = 0.0

    def __call__(self) -> float:
        return self.now_s


def _network(seed: int = 1) -> LinkNetwork:
    network = LinkNetwork(LinksConfig.load(), seed)
    for node, role in (("e1", "edge"), ("e2", "edge"), ("f", "fog"), ("g", "ground")):
        network.add_node(node, role)
    return network


def test_lockstep_delivers_in_arrival_order_and_not_before():
    """Datagrams appear at receive() once the clock passes their arrival, earliest first."""
    clock = _Clock()
    port = InProcessPort(_network(), clock)
    reference = _network()  # same seed: the same arrival times, computed directly
    expected = []
    for k in range(300):
        clock.now_s = k * 2e-4
        src = "e1" if k % 2 else "e2"
        data = k.to_bytes(2, "big") * (1 + k % 50)
        port.send(src, "f", data)
        arrival, _ = reference.submit(clock.now_s, src, "f", len(data))
        if arrival is not None:
            expected.append((arrival, data))
    expected.sort(key=lambda item: item[0])
    received = []
    clock.now_s = 0.0
    while clock.now_s < 0.2:
        for data in port.receive("f"):
            received.append((clock.now_s, data))
        clock.now_s += 1e-4
    assert [d for _, d in received] == [d for _, d in expected]
    for (seen_s, _), (arrival_s, _) in zip(received, expected, strict=True):
        assert arrival_s <= seen_s < arrival_s + 1e-4 + 1e-12
    assert port.receive("e1") == []
    # the edges' latencies overlap, so arrival order is not send order: the test has teeth
    sent_order = sorted(expected, key=lambda item: int.from_bytes(item[1][:2], "big"))
    assert sent_order != expected


def test_full_queue_drops_and_counts_never_blocks():
    """A burst above the SiK queue drops the excess (counted); what fits still arrives."""
    clock = _Clock()
    network = _network()
    port = InProcessPort(network, clock)
    network.set_position("g", (0.0, 0.0, 0.0))
    for _ in range(50):
        port.send("g", "e1", b"x" * 200)
    assert port.last_drop is Drop.QUEUE
    rec = network.records(10.0)["classes"]["edge-ground"]
    assert rec["drops"]["queue"] >= 40
    clock.now_s = 10.0
    assert len(port.receive("e1")) == rec["datagrams_delivered"] > 0


def test_oversized_datagram_raises():
    """An oversized datagram raises DatagramTooLargeError (SiK carries 280 B at most)."""
    port = InProcessPort(_network(), _Clock())
    with pytest.raises(DatagramTooLargeError):
        port.send("g", "e1", b"x" * 281)
