"""A node's messages of one topic, handed to a decision loop once each (``companion.net.radio``)."""

from __future__ import annotations

from types import SimpleNamespace

from companion.net.radio import Radio, open_radio


class FakeNode:
    """What :class:`Radio` uses of ``companion.net.AsyncNode``."""

    def __init__(self) -> None:
        self.handlers: dict = {}
        self.sent: list = []
        self.closed = False

    def on(self, topic: str, handler) -> None:
        self.handlers[topic] = handler

    def broadcast(self, topic: str, body) -> int:
        self.sent.append((topic, body))
        return 1

    def close(self) -> None:
        self.closed = True


def test_messages_of_the_topic_are_handed_over_once_at_the_next_poll() -> None:
    """Only the radio's topic is subscribed; what arrived between two polls comes at the
    second, once; closed, it neither sends nor keeps its node."""
    node = FakeNode()
    radio = Radio(node, "aco")
    assert set(node.handlers) == {"aco"}
    for k in range(3):
        node.handlers["aco"](SimpleNamespace(topic="aco", body={"k": k}))
    assert [e.body["k"] for e in radio.poll()] == [0, 1, 2] and radio.poll() == []
    assert radio.heard == 3
    assert radio.broadcast("aco", {"k": 9}) == 1 and node.sent == [("aco", {"k": 9})]
    radio.close()
    assert node.closed and radio.broadcast("aco", {}) == 0


def test_without_a_network_it_is_a_lone_vehicles_radio(monkeypatch) -> None:
    """No ``SWARMSITL_NET``: a radio without a node, and the reason logged."""
    monkeypatch.delenv("SWARMSITL_NET", raising=False)
    monkeypatch.delenv("SWARMSITL_NODE", raising=False)
    said = []
    radio = open_radio("aco", lambda name, **data: said.append((name, data)))
    assert radio.node is None and radio.poll() == [] and radio.broadcast("aco", {}) == 0
    assert said and said[0][0] == "no_network"
