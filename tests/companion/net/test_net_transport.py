"""Transports: three nodes over real UDP sockets on 127.0.0.1, and the in-process port adapter."""

from __future__ import annotations

import select
import time

import pytest
from netfakes import FakePort

from companion.net import NetConfig, Node, PortTransport, Transport, UdpTransport
from harness.run.ports import free_port_block

pytestmark = pytest.mark.sockets

BASE = free_port_block(8)
"""Ports of the nodes below, from the suite's allocator (this xdist worker's own slice)."""

UDP_CONFIG = NetConfig.from_dict(
    {
        "nodes": {
            "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE}"},
            "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 1}", "groups": ["cluster1"]},
            "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 2}", "groups": ["cluster1"]},
        }
    }
)


@pytest.fixture
def udp_nodes():
    clock = time.monotonic
    nodes = {}
    try:
        for node_id in UDP_CONFIG.nodes:
            nodes[node_id] = Node(node_id, UDP_CONFIG, UdpTransport(UDP_CONFIG, node_id), clock)
        yield nodes
    finally:
        for node in nodes.values():
            node.close()


def collect(node, count, wait_s=5.0):
    """Poll until ``count`` messages arrived (the bound only guards against a hang)."""
    out = []
    end = time.monotonic() + wait_s
    while len(out) < count and time.monotonic() < end:
        select.select([node.transport.fileno()], [], [], 0.05)
        out += node.poll()
    return out


def test_udp_transport_is_a_transport():
    transport = UdpTransport(UDP_CONFIG, "cloud")
    try:
        assert isinstance(transport, Transport)
        assert transport.fileno() is not None
    finally:
        transport.close()


def test_unicast_group_broadcast_over_real_udp(udp_nodes):
    udp_nodes["edge1"].send("fog1", "telemetry", {"battery_v": 15.8})
    assert udp_nodes["cloud"].send_group("cluster1", "plan", [1, 2]) == 2
    assert udp_nodes["fog1"].broadcast("hello", b"\x01") == 2
    fog = collect(udp_nodes["fog1"], 2)
    edge = collect(udp_nodes["edge1"], 2)
    cloud = collect(udp_nodes["cloud"], 1)
    assert sorted((e.src, e.topic) for e in fog) == [("cloud", "plan"), ("edge1", "telemetry")]
    assert sorted((e.src, e.topic, e.body) for e in edge) == [
        ("cloud", "plan", [1, 2]),
        ("fog1", "hello", b"\x01"),
    ]
    assert [(e.src, e.topic) for e in cloud] == [("fog1", "hello")]
    assert udp_nodes["fog1"].stats.peers["edge1"].received["data"].messages == 1


def test_request_reply_over_real_udp(udp_nodes):
    udp_nodes["cloud"].on("double", lambda env: env.body * 2)
    pending = udp_nodes["edge1"].request("cloud", "double", 21, timeout_s=5.0)
    end = time.monotonic() + 5.0
    while not pending.done and time.monotonic() < end:
        for node in udp_nodes.values():
            node.poll()
        time.sleep(0.001)
    assert pending.reply.body == 42
    assert udp_nodes["edge1"].stats.link_classes()["edge-cloud"]["rtt_s"] == [pending.rtt_s]


def test_send_errors_are_counted_not_raised():
    """A route the OS refuses (broadcast address without SO_BROADCAST) counts a send error."""
    config = NetConfig.from_dict(
        {
            "nodes": {
                "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 3}"},
                "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 4}"},
            },
            "routes": {"fog1": f"255.255.255.255:{BASE + 7}"},
        }
    )
    transport = UdpTransport(config, "edge1")
    try:
        transport.send("fog1", b"x")
        assert transport.send_errors == 1
    finally:
        transport.close()


def test_icmp_unreachable_does_not_break_receive():
    """Sending to a closed port makes Linux report ECONNREFUSED on a later recv: it is counted."""
    transport = UdpTransport(UDP_CONFIG, "edge1")  # nobody listens on fog1's port
    try:
        transport.send("fog1", b"x")
        time.sleep(0.05)  # let the ICMP message come back
        assert transport.receive() == []
        assert transport.receive_errors <= 1
    finally:
        transport.close()


def test_port_transport_passes_node_ids_to_the_port():
    port = FakePort()
    a = PortTransport(port, "edge1")
    b = PortTransport(port, "fog1")
    assert isinstance(a, Transport) and a.fileno() is None
    a.send("fog1", b"hi")
    assert port.sent == [("edge1", "fog1", b"hi")]
    assert b.receive() == [b"hi"] and b.receive() == [] and a.receive() == []


def test_bind_error_names_the_node_and_field():
    first = UdpTransport(UDP_CONFIG, "cloud")
    try:
        with pytest.raises(OSError, match=r"node cloud cannot bind nodes\.cloud\.address"):
            UdpTransport(UDP_CONFIG, "cloud")
    finally:
        first.close()


def test_host_names_are_resolved():
    config = NetConfig.from_dict(
        {
            "nodes": {
                "edge1": {"role": "edge", "address": f"localhost:{BASE + 5}"},
                "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 6}"},
            },
            "routes": {"fog1": f"localhost:{BASE + 6}"},
        }
    )
    edge = UdpTransport(config, "edge1")
    fog = UdpTransport(config, "fog1")
    try:
        edge.send("fog1", b"a")
        fog.send("edge1", b"b")
        got = {}
        for name, transport in (("fog1", fog), ("edge1", edge)):
            select.select([transport.fileno()], [], [], 5.0)
            got[name] = transport.receive()
        assert got == {"fog1": [b"a"], "edge1": [b"b"]}
        assert edge.send_errors == fog.send_errors == 0
    finally:
        edge.close()
        fog.close()
