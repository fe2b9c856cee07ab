"""LinkRouter over real UDP sockets: three nodes with plain sockets, a stand-in network.

The network stand-in gives each ordered pair a fixed delay, drops what its policy says and
refuses datagrams above 1000 B, as ``LinkNetwork.submit`` would. The router is polled on a fake
simulation clock (lockstep) or driven by RouterThread (wall time x speed); only orderings and
counts are asserted, never timings.
"""

from __future__ import annotations

import select
import socket
import time

import pytest

from harness.run.ports import free_port_block
from sitl.devices.link_router import (
    FAULT,
    OVERSIZE,
    REFUSED,
    SELF,
    LinkRouter,
    RouterNode,
    RouterThread,
)
from sitl.links.channel import DatagramTooLargeError, Drop

pytestmark = pytest.mark.sockets

DELAY_S = {
    ("a", "b"): 0.2,
    ("a", "c"): 0.3,
    ("b", "a"): 0.2,
    ("b", "c"): 0.1,
    ("c", "a"): 0.05,
    ("c", "b"): 0.05,
}
LIMIT_BYTES = 1000


class StandInNetwork:
    """Fixed delay per pair; drops every datagram b -> a; refuses > LIMIT_BYTES."""

    def __init__(self) -> None:
        self.submitted: list[tuple[float, str, str, int]] = []

    def submit(self, now_s: float, src: str, dst: str, size: int):
        self.submitted.append((now_s, src, dst, size))
        if "z" in (src, dst):
            raise ValueError("unknown node 'z'")
        if size > LIMIT_BYTES:
            raise DatagramTooLargeError(f"{size} B exceeds {LIMIT_BYTES} B")
        if (src, dst) == ("b", "a"):
            return None, Drop.LOSS
        return now_s + DELAY_S[(src, dst)], None


class Node:
    """A node's own plain UDP socket (what companion code on a Pi would open)."""

    def __init__(self, node_id: str) -> None:
        self.node_id = node_id
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.inbox: list[tuple[bytes, tuple[str, int]]] = []

    @property
    def address(self) -> tuple[str, int]:
        return self.sock.getsockname()

    def receive(self, wait_s: float = 0.0) -> None:
        if wait_s:
            select.select([self.sock], [], [], wait_s)
        while True:
            try:
                data, address = self.sock.recvfrom(65535)
            except BlockingIOError:
                return
            self.inbox.append((data, address))


@pytest.fixture
def net():
    nodes = {name: Node(name) for name in "abc"}
    network = StandInNetwork()
    router = LinkRouter(
        network.submit,
        [RouterNode(n.node_id, "edge", n.address, 0) for n in nodes.values()],
    )
    yield nodes, network, router
    router.close()
    for n in nodes.values():
        n.sock.close()


def send(nodes, router, src: str, dst: str, data: bytes) -> None:
    nodes[src].sock.sendto(data, router.proxy_address(dst))


def settle(router: LinkRouter, expected_received: int, now_s: float) -> None:
    """Poll at ``now_s`` until the router has read ``expected_received`` datagrams.

    Loopback delivery is immediate; the wall-clock guard only covers a scheduler hiccup.
    """
    deadline = time.monotonic() + 5.0
    while True:
        router.poll(now_s)
        got = sum(p.received for p in router.stats.pairs.values()) + sum(
            router.stats.unknown_senders.values()
        )
        if got >= expected_received or time.monotonic() > deadline:
            return
        select.select(router.filenos(), [], [], 0.01)


def test_deliveries_follow_their_modelled_arrival_times(net):
    """a->c (0.3 s) sent before b->c (0.1 s): c gets b's first, each from the sender's route."""
    nodes, _, router = net
    send(nodes, router, "a", "c", b"from a")
    send(nodes, router, "b", "c", b"from b")
    send(nodes, router, "a", "b", b"a to b")
    settle(router, 3, 0.0)
    assert router.in_flight == 3
    assert router.next_arrival_s == pytest.approx(0.1)
    order = []
    for k in range(1, 41):
        now = k * 0.01
        router.poll(now)
        for n in nodes.values():
            before = len(n.inbox)
            n.receive()  # loopback: what the router sent is already in the socket
            order += [(n.node_id, d, addr) for d, addr in n.inbox[before:]]
    assert [(dst, data) for dst, data, _ in order] == [
        ("c", b"from b"),
        ("b", b"a to b"),
        ("c", b"from a"),
    ]
    routes = {dst + ":" + data.decode(): addr for dst, data, addr in order}
    assert routes["c:from b"] == router.proxy_address("b")
    assert routes["c:from a"] == router.proxy_address("a")
    assert router.stats.pairs[("a", "c")].forwarded == 1
    assert router.in_flight == 0


def test_nothing_is_delivered_before_its_time(net):
    """Polled at 0.29 s, a->c (0.3 s) is still held; at 0.3 s it is sent."""
    nodes, _, router = net
    send(nodes, router, "a", "c", b"x")
    settle(router, 1, 0.0)
    router.poll(0.29)
    nodes["c"].receive(0.05)
    assert nodes["c"].inbox == []
    router.poll(0.3)
    nodes["c"].receive(1.0)
    assert [d for d, _ in nodes["c"].inbox] == [b"x"]


def test_a_reply_to_the_source_address_goes_back_through_the_router(net):
    """c answers the address a's datagram came from: it is submitted as c -> a and delivered."""
    nodes, network, router = net
    send(nodes, router, "a", "c", b"ping")
    settle(router, 1, 0.0)
    router.poll(0.3)
    nodes["c"].receive(1.0)
    ((_, source),) = nodes["c"].inbox
    nodes["c"].sock.sendto(b"pong", source)
    settle(router, 2, 0.3)
    router.poll(0.35)
    nodes["a"].receive(1.0)
    assert [(d, addr) for d, addr in nodes["a"].inbox] == [(b"pong", router.proxy_address("c"))]
    assert [(s, d) for _, s, d, _ in network.submitted] == [("a", "c"), ("c", "a")]


def test_the_network_drops_what_it_says_and_counts_it(net):
    """b -> a is dropped by the stand-in (loss): never delivered, counted by reason."""
    nodes, _, router = net
    for k in range(5):
        send(nodes, router, "b", "a", b"lost %d" % k)
    settle(router, 5, 0.0)
    router.poll(10.0)
    nodes["a"].receive(0.1)
    assert nodes["a"].inbox == []
    pair = router.stats.pairs[("b", "a")]
    assert (pair.received, pair.forwarded, pair.dropped) == (5, 0, {"loss": 5})


def test_a_silenced_transmitter_drops_what_its_node_sends_from_then_on(net):
    """a's radio_tx fails at 1 s: what it sent before still arrives, what it sends after never
    leaves (not submitted to the network), counted as fault; a still receives."""
    nodes, network, router = net
    send(nodes, router, "a", "c", b"before")
    settle(router, 1, 0.0)
    router.silence("a", tx=True, rx=False)
    send(nodes, router, "a", "c", b"after 1")
    send(nodes, router, "a", "b", b"after 2")
    send(nodes, router, "c", "a", b"to a")
    settle(router, 4, 1.0)
    router.poll(2.0)
    nodes["c"].receive(1.0)
    nodes["a"].receive(1.0)
    assert [d for d, _ in nodes["c"].inbox] == [b"before"]
    assert [d for d, _ in nodes["a"].inbox] == [b"to a"]
    assert [(s, d) for _, s, d, _ in network.submitted] == [("a", "c"), ("c", "a")]
    stats = router.stats.pairs
    assert stats[("a", "c")].dropped == {FAULT: 1} and stats[("a", "c")].forwarded == 1
    assert stats[("a", "b")].dropped == {FAULT: 1}


def test_a_silenced_receiver_loses_what_reaches_its_port_from_then_on(net):
    """c's radio_rx fails at 0.1 s: a->c in flight (due 0.3 s) is dropped on arrival, b->c sent
    after too; c still sends; radio (both) silences both ways."""
    nodes, _, router = net
    send(nodes, router, "a", "c", b"in flight")
    settle(router, 1, 0.0)
    router.silence("c", tx=False, rx=True)
    send(nodes, router, "b", "c", b"after")
    send(nodes, router, "c", "b", b"from c")
    settle(router, 3, 0.1)
    router.poll(1.0)
    nodes["b"].receive(1.0)
    nodes["c"].receive(0.05)  # loopback: what the router sent is there already
    assert nodes["c"].inbox == []
    assert [d for d, _ in nodes["b"].inbox] == [b"from c"]
    stats = router.stats.pairs
    assert stats[("a", "c")].dropped == {FAULT: 1} and stats[("a", "c")].forwarded == 0
    assert stats[("b", "c")].dropped == {FAULT: 1}
    router.silence("b", tx=True, rx=True)
    send(nodes, router, "b", "a", b"x")
    send(nodes, router, "a", "b", b"y")
    settle(router, 5, 1.0)
    router.poll(2.0)
    nodes["b"].receive(0.05)
    assert [d for d, _ in nodes["b"].inbox] == [b"from c"]
    assert stats[("b", "a")].dropped == {FAULT: 1} and stats[("a", "b")].dropped == {FAULT: 1}
    with pytest.raises(KeyError, match="no node 'z'"):
        router.silence("z", tx=True, rx=True)


def test_unknown_senders_and_oversize_datagrams_are_counted_and_dropped(net):
    """A stranger's datagram and one above the link limit never reach the node."""
    nodes, _, router = net
    stranger = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        stranger.sendto(b"who am i", router.proxy_address("a"))
        send(nodes, router, "c", "a", bytes(LIMIT_BYTES + 1))
        send(nodes, router, "c", "a", bytes(LIMIT_BYTES))
        settle(router, 3, 0.0)
        router.poll(1.0)
        nodes["a"].receive(1.0)
    finally:
        stranger.close()
    assert [len(d) for d, _ in nodes["a"].inbox] == [LIMIT_BYTES]
    assert router.stats.unknown_senders == {"a": 1}
    assert router.stats.pairs[("c", "a")].dropped == {OVERSIZE: 1}


def test_what_the_network_refuses_or_a_node_sends_itself_is_counted_not_raised():
    """A node the network does not know (ValueError) and a self-send are dropped and counted."""
    nodes = {name: Node(name) for name in "az"}
    router = LinkRouter(
        StandInNetwork().submit,
        [RouterNode(n.node_id, "edge", n.address, 0) for n in nodes.values()],
    )
    try:
        send(nodes, router, "a", "z", b"to a stranger")
        send(nodes, router, "a", "a", b"to myself")
        settle(router, 2, 0.0)
        router.poll(1.0)
        nodes["z"].receive(0.1)
    finally:
        router.close()
        for n in nodes.values():
            n.sock.close()
    assert nodes["z"].inbox == []
    assert router.stats.pairs[("a", "z")].dropped == {REFUSED: 1}
    assert router.stats.pairs[("a", "a")].dropped == {SELF: 1}


def test_duplicate_nodes_and_taken_ports_are_refused():
    """Two nodes with one id, or a proxy port in use, fail at construction naming it."""
    network = StandInNetwork()
    base = free_port_block(2)
    node = RouterNode("a", "edge", ("127.0.0.1", base), 0)
    with pytest.raises(ValueError, match="node_id"):
        LinkRouter(network.submit, [node, RouterNode("a", "fog", ("127.0.0.1", base + 1), 0)])
    holder = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    holder.bind(("127.0.0.1", 0))
    try:
        taken = holder.getsockname()[1]
        with pytest.raises(OSError, match="proxy of node a"):
            LinkRouter(network.submit, [RouterNode("a", "edge", ("127.0.0.1", base), taken)])
    finally:
        holder.close()


def test_router_thread_delivers_everything_in_modelled_order():
    """RouterThread at 20x: three datagrams to c arrive, in order of their modelled arrival."""
    nodes = {name: Node(name) for name in "abc"}
    network = StandInNetwork()
    router = LinkRouter(
        network.submit, [RouterNode(n.node_id, "edge", n.address, 0) for n in nodes.values()]
    )
    thread = RouterThread(router, speed=20.0)
    try:
        thread.start()
        send(nodes, router, "a", "c", b"slow")  # 0.3 s simulated
        send(nodes, router, "b", "c", b"fast")  # 0.1 s simulated
        send(nodes, router, "a", "b", b"to b")  # 0.2 s simulated
        deadline = time.monotonic() + 10.0
        while len(nodes["c"].inbox) < 2 and time.monotonic() < deadline:
            nodes["c"].receive(0.05)
        while not nodes["b"].inbox and time.monotonic() < deadline:
            nodes["b"].receive(0.05)
    finally:
        thread.stop()
        router.close()
        for n in nodes.values():
            n.sock.close()
    assert thread.error is None
    assert [d for d, _ in nodes["c"].inbox] == [b"fast", b"slow"]
    assert [d for d, _ in nodes["b"].inbox] == [b"to b"]
