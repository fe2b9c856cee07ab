"""The lockstep transport: datagrams held in simulation time until the link delivers them.

``InProcessPort`` is what node-messaging code sends through inside the harness: ``send`` asks the
:class:`LinkNetwork` when (and whether) the datagram arrives and keeps it in the destination's
:class:`DeliveryQueue`; ``receive`` returns what has arrived by ``clock()``. Duck-typed on
purpose (bytes in, bytes out, node ids as strings): the messaging library wraps this interface
without importing the simulator.
"""

from __future__ import annotations

from collections.abc import Callable

from sitl.links.channel import DeliveryQueue, Drop
from sitl.links.network import LinkNetwork


class InProcessPort:
    """Lockstep datagram transport through a :class:`LinkNetwork`.

    Args:
        network: the nodes and their links.
        clock: returns the current simulation time, s.
    """

    def __init__(self, network: LinkNetwork, clock: Callable[[], float]) -> None:
        self.network = network
        self.clock = clock
        self._queues: dict[str, DeliveryQueue] = {}
        self.last_drop: Drop | None = None
        """Why the last ``send`` was dropped (None: it will arrive)."""

    def send(self, src: str, dst: str, data: bytes) -> None:
        """Send ``data`` from ``src`` to ``dst`` now; a dropped datagram is counted, not raised.

        Raises:
            DatagramTooLargeError: ``data`` exceeds the link's largest datagram.
            ValueError: an unknown node.
        """
        arrival, drop = self.network.submit(self.clock(), src, dst, len(data))
        self.last_drop = drop
        if arrival is not None:
            queue = self._queues.get(dst)
            if queue is None:
                queue = self._queues[dst] = DeliveryQueue()
            queue.push(arrival, bytes(data))

    def receive(self, node_id: str) -> list[bytes]:
        """Every datagram that reached ``node_id`` by ``clock()``, in order of arrival."""
        queue = self._queues.get(node_id)
        if queue is None or not queue:
            return []
        return queue.pop_due(self.clock())

    def next_arrival_s(self, node_id: str) -> float:
        """When the next datagram for ``node_id`` arrives, s (inf: nothing in flight)."""
        queue = self._queues.get(node_id)
        return queue.next_arrival_s if queue is not None else float("inf")
