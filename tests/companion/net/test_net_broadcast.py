"""A broadcast is exactly its unicasts: same datagrams, link draws, deliveries and stats.

``Node.broadcast`` and ``send_group`` encode the body once and splice each copy's header; the
reference they must match is the plain path, one ``Node.send`` per recipient in the order of
the configuration. Two identical worlds (same seed, same link models, same positions) are run
side by side, one broadcasting, one sending the unicasts, and everything observable is
compared: the datagrams on the wire, what each node receives and when, the nodes' records and
the link network's.
"""

from __future__ import annotations

import numpy as np
import pytest
from netfakes import CONFIG, FakePort, ManualClock, make_nodes

from companion.net import NetConfig, Node, PortTransport
from harness.run.ports import free_port_block
from sitl.links.channel import DatagramTooLargeError
from sitl.links.config import LinksConfig
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork

ROLES = ["edge"] * 9 + ["fog"] * 2 + ["cloud", "ground"]
"""Every link class of the shipped presets: WiFi with Bernoulli and Gilbert-Elliott loss,
LTE (log-normal delays, bursts), wired, and the SiK radio (280-B datagrams, in order)."""
BASE = free_port_block(len(ROLES))
"""In-process nodes bind nothing; their addresses still have to be distinct ports."""
LINKS = LinksConfig.from_dict(
    {"presets": {"wifi": {"loss": {"mean_loss": 0.2}}, "lte": {"loss": {"mean_loss": 0.2}}}}
)
"""Lossy enough that a few rounds drop datagrams to loss, range and bursts."""


class _World:
    """Nodes over the link models in simulation time, placed across the WiFi range edge."""

    def __init__(self, seed: int) -> None:
        self.t_s = 0.0
        self.network = LinkNetwork(LINKS, seed)
        self.ids = [f"{role}{k}" for k, role in enumerate(ROLES)]
        place = np.random.default_rng(seed)
        for node_id, role in zip(self.ids, ROLES, strict=True):
            self.network.add_node(node_id, role)
            if role in ("edge", "fog"):  # up to ~140 m apart: inside, across and beyond 100 m
                self.network.set_position(node_id, (*place.uniform(0.0, 100.0, 2), 20.0))
        self.port = InProcessPort(self.network, lambda: self.t_s)
        config = NetConfig.from_dict(
            {
                "nodes": {
                    n: {"role": r, "address": f"127.0.0.1:{BASE + k}", "groups": ["g"]}
                    for k, (n, r) in enumerate(zip(self.ids, ROLES, strict=True))
                }
            }
        )
        self.nodes = [
            Node(n, config, PortTransport(self.port, n), lambda: self.t_s) for n in self.ids
        ]
        self.received: list[tuple[float, str, str, str, int, float, object]] = []

    def poll(self) -> None:
        for node in self.nodes:
            for env in node.poll():
                self.received.append(
                    (self.t_s, env.dst, env.src, env.topic, env.msg_id, env.sent_s, env.body)
                )

    def unicasts(self, node: Node, topic: str, body: object) -> None:
        for dst in self.ids:
            if dst != node.node_id:
                node.send(dst, topic, body)

    def observed(self) -> dict:
        return {
            "received": self.received,
            "records": {n.node_id: n.records() for n in self.nodes},
            "links": self.network.records(self.t_s),
            "fault_drops": self.port.fault_drops,
        }


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_broadcast_over_lossy_links_equals_the_unicasts(seed: int) -> None:
    """Same drops, arrival times, bodies, per-peer stats and link records as N-1 sends."""
    fanout, plain = _World(seed), _World(seed)
    body = {"p": [1.5, -2.25, 20.0], "k": 3}
    for step in range(40):
        for world in (fanout, plain):
            world.t_s = 0.05 * step
            world.poll()
        for k, (a, b) in enumerate(zip(fanout.nodes, plain.nodes, strict=True)):
            if (step + k) % 3 == 0:
                body["k"] = step * 100 + k
                a.broadcast("pos", body)
                plain.unicasts(b, "pos", body)
    for world in (fanout, plain):
        world.t_s = 10.0
        world.poll()
    observed = fanout.observed()
    assert observed == plain.observed()
    drops = observed["links"]["classes"]
    assert drops["edge-edge"]["drops"]["loss"] > 0 and drops["edge-edge"]["drops"]["range"] > 0
    assert drops["fog-cloud"]["drops"]["loss"] > 0
    assert len(observed["received"]) > 1000


def test_broadcast_stopped_by_a_link_limit_equals_the_unicasts_up_to_it() -> None:
    """A body too big for the SiK radio (280 B) raises at the ground node in both worlds,
    after the same earlier recipients got it and were counted."""
    fanout, plain = _World(5), _World(5)
    big = b"x" * 400
    with pytest.raises(DatagramTooLargeError):
        fanout.nodes[0].broadcast("img", big)
    with pytest.raises(DatagramTooLargeError):
        plain.unicasts(plain.nodes[0], "img", big)
    for world in (fanout, plain):
        world.t_s = 1.0
        world.poll()
    observed = fanout.observed()
    assert observed == plain.observed()
    sent = observed["records"][fanout.ids[0]]["peers"]
    assert sorted(sent) == sorted(fanout.ids[1:-1])  # everyone but the sender and the ground node


def test_group_send_and_broadcast_put_the_unicasts_datagrams_on_the_wire() -> None:
    """Byte for byte the datagrams of the unicasts, in the same order, with the same ids."""
    clock = ManualClock()
    fanout_port, plain_port = FakePort(), FakePort()
    fanout = make_nodes(fanout_port, clock, "cloud", "fog1", "edge1", "edge2")
    plain = make_nodes(plain_port, clock, "cloud", "fog1", "edge1", "edge2")
    clock.t_s = 3.25
    fanout["fog1"].send_group("cluster1", "hello", {"n": np.arange(3)})
    fanout["fog1"].broadcast("all", None, category="control")
    for dst in ("edge1", "edge2"):
        plain["fog1"].send(dst, "hello", {"n": np.arange(3)})
    for dst in CONFIG.nodes:
        if dst != "fog1":
            plain["fog1"].send(dst, "all", None, category="control")
    assert fanout_port.sent == plain_port.sent
    assert fanout["fog1"].stats.to_dict() == plain["fog1"].stats.to_dict()
