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
        self._deaf: set[str] = set()
        self._mute: set[str] = set()
        self.fault_drops: dict[str, int] = {}
        """Node id -> datagrams its faulted radio did not send or did not hear."""

    def silence(self, node_id: str, tx: bool = False, rx: bool = False) -> None:
        """From now on ``node_id`` sends nothing (``tx``) and/or hears nothing (``rx``).

        A radio fault at the node's port: what it would send never reaches the link (no airtime,
        no link statistics); what reaches it, already in flight or not, is discarded on arrival.
        """
        if tx:
            self._mute.add(node_id)
        if rx:
            self._deaf.add(node_id)

    def _count_fault(self, node_id: str, k: int) -> None:
        self.fault_drops[node_id] = self.fault_drops.get(node_id, 0) + k

    def send(self, src: str, dst: str, data: bytes) -> None:
        """Send ``data`` from ``src`` to ``dst`` now; a dropped datagram is counted, not raised.

        Raises:
            DatagramTooLargeError: ``data`` exceeds the link's largest datagram.
            ValueError: an unknown node.
        """
        if src in self._mute:
            self.last_drop = Drop.FAULT
            self._count_fault(src, 1)
            return
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
        due = queue.pop_due(self.clock())
        if node_id in self._deaf:
            self._count_fault(node_id, len(due))
            return []
        return due

    def next_arrival_s(self, node_id: str) -> float:
        """When the next datagram for ``node_id`` arrives, s (inf: nothing in flight)."""
        queue = self._queues.get(node_id)
        return queue.next_arrival_s if queue is not None else float("inf")
