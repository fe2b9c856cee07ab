"""A messaging node as a companion's decision loop uses it: one topic, read once per decision.

A program that decides at a fixed period (the full-stack adapters of ``companion.scripts.caravan``
and ``companion.scripts.aco_swarm``) wants the messages of its topic that arrived since its last
decision, as the swarm engine's ``Node.poll`` hands them over. :class:`Radio` wraps an
:class:`~companion.net.AsyncNode` so: messages of the topic are kept as they arrive and handed
over at the next :meth:`Radio.poll`; without a network configured it is a lone vehicle's radio.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class Radio:
    """A node's messages of one topic, kept until polled (``poll``, ``broadcast``, ``close``)."""

    def __init__(self, node: Any | None, topic: str) -> None:
        self.node = node
        self.topic = topic
        self._kept: list[Any] = []
        self.heard = 0
        """Messages of the topic received."""
        if node is not None:
            node.on(topic, self._keep)

    def _keep(self, envelope: Any) -> None:
        self._kept.append(envelope)
        self.heard += 1

    def poll(self) -> list[Any]:
        """The messages that arrived since the last call."""
        out, self._kept = self._kept, []
        return out

    def broadcast(self, topic: str, body: Any) -> int:
        """To every other node (nothing once closed or without a network)."""
        return 0 if self.node is None else self.node.broadcast(topic, body)

    def close(self) -> None:
        """Stop sending and receiving for good."""
        if self.node is not None:
            self.node.close()
            self.node = None


def open_radio(topic: str, log: Callable[..., None]) -> Radio:
    """This vehicle's node from ``SWARMSITL_NET``/``SWARMSITL_NODE``, started; none if unset.

    ``log("no_network", reason=...)`` says why there is none.
    """
    from companion.net import AsyncNode, NetConfigError

    try:
        node = AsyncNode.from_env()
    except NetConfigError as exc:
        log("no_network", reason=str(exc))
        return Radio(None, topic)
    node.start()
    return Radio(node, topic)
