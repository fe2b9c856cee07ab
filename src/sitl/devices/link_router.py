"""The paced UDP router of node messaging: datagrams held until their modelled arrival time.

Companion processes talk plain UDP; in the harness each node's ``routes`` point at the router
instead of at each other. The router binds one UDP socket per node on its ``proxy_port`` (the
address other nodes send to in order to reach that node). A datagram arriving on node j's proxy
socket from node i's ``address`` is submitted to the link network as (i -> j); if the network
delivers it, at its arrival time the router sends it to j's ``address`` *from i's proxy socket*,
so j sees it come from i's route and a reply to the source address goes back through the router.

Nothing here knows the link models: ``submit(now_s, src, dst, payload_bytes) -> (arrival_s |
None, Drop | None)`` is injected (a ``LinkNetwork``'s, or a stand-in), so the same router runs
any network. Time is whatever the driver passes to :meth:`LinkRouter.poll`: the simulation clock
(``harness.sim.simulation.Simulation`` polls it with the MAVLink links) or wall time x speed
(:class:`RouterThread`, a standalone run without physics).

A datagram from an address that is no node's is counted and dropped; one above the link's
``max_datagram_bytes`` is dropped, counted and logged (UDP cannot tell its sender). Nothing
blocks: a poll reads what is ready and sends what is due.

A node's radio can fail (:meth:`LinkRouter.silence`, a scenario's ``radio`` faults): from then on
what it sends is dropped as it reaches the router (before the network: nothing is transmitted),
and what is sent to it is dropped when it would reach its port (the network carried it; the
dead receiver loses it), both counted under :data:`FAULT`.
"""

from __future__ import annotations

import contextlib
import logging
import math
import select
import socket
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from sitl.links.channel import DatagramTooLargeError, DeliveryQueue, Drop

log = logging.getLogger(__name__)

Address = tuple[str, int]
Submit = Callable[[float, str, str, int], tuple[float | None, Drop | None]]
"""``submit(now_s, src, dst, payload_bytes) -> (arrival_s or None, why it was dropped)``."""

OVERSIZE = "oversize"
"""Drop reason of a datagram above the link's size limit."""
SELF = "self"
"""Drop reason of a datagram a node sent to its own proxy port."""
REFUSED = "refused"
"""Drop reason of a datagram the network refused (it does not know the node)."""
FAULT = "fault"
"""Drop reason of a datagram a silenced radio lost: its sender's, or its destination's."""
MAX_DATAGRAM_BYTES = 65535
MAX_READS_PER_SOCKET = 256
"""Datagrams read from one proxy socket per poll; the rest wait for the next poll."""


@dataclass(frozen=True)
class RouterNode:
    """One node of the messaging network as the router sees it."""

    node_id: str
    """The node's id in the link network (``edge1``, ``fog1``, ``cloud``)."""
    role: str
    """Its role (``edge``, ``fog``, ``cloud``): documentation and reports."""
    address: Address
    """(host, port) the node's socket is bound to: where it receives, and the source address
    of what it sends (use the address ``recvfrom`` reports, e.g. 127.0.0.1, not 0.0.0.0)."""
    proxy_port: int
    """UDP port of the router that stands for this node: other nodes send here to reach it."""

    def __post_init__(self) -> None:
        if not isinstance(self.node_id, str) or not self.node_id:
            raise ValueError(f"node_id must be a non-empty string, got {self.node_id!r}")
        if not 0 <= self.proxy_port <= 65535:
            raise ValueError(
                f"proxy_port of {self.node_id} must be 0..65535, got {self.proxy_port}"
            )
        host, port = self.address
        if not 1 <= port <= 65535:
            raise ValueError(f"address port of {self.node_id} must be 1..65535, got {port}")
        object.__setattr__(self, "address", (str(host), int(port)))


@dataclass(slots=True)
class PairStats:
    """What the router did with the datagrams from one node to another."""

    received: int = 0
    received_bytes: int = 0
    forwarded: int = 0
    """Sent on to the destination at their arrival time."""
    forwarded_bytes: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    """Dropped by reason: the network's (``loss``, ``queue``, ``range``, ...), or the router's
    (``oversize``, ``self``, ``refused``, ``fault``)."""
    send_errors: int = 0
    """Failed ``sendto`` towards the destination (nobody listening there)."""


@dataclass(slots=True)
class RouterStats:
    """Everything the router counted."""

    pairs: dict[tuple[str, str], PairStats] = field(default_factory=dict)
    """Per (source, destination) node ids."""
    unknown_senders: dict[str, int] = field(default_factory=dict)
    """Datagrams arriving at a node's proxy port from an address that is no node's, by the
    node they were sent to."""

    def pair(self, src: str, dst: str) -> PairStats:
        """The counts of (src -> dst), created empty on first use."""
        stats = self.pairs.get((src, dst))
        if stats is None:
            stats = self.pairs[(src, dst)] = PairStats()
        return stats


def _resolve(host: str, port: int) -> Address:
    info = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
    address = info[0][4]
    return (address[0], address[1])


class LinkRouter:
    """Holds node-to-node datagrams until the link network says they arrive.

    Args:
        submit: the link network's ``submit(now_s, src, dst, payload_bytes)``.
        nodes: the nodes; ids, addresses and proxy ports must be unique.
        bind_addr: address the proxy sockets bind to.

    Raises:
        ValueError: duplicate node ids, addresses or proxy ports.
        OSError: a proxy port is taken (the message names the node).
    """

    def __init__(
        self, submit: Submit, nodes: Sequence[RouterNode], bind_addr: str = "127.0.0.1"
    ) -> None:
        self._submit = submit
        self.nodes = tuple(nodes)
        self.stats = RouterStats()
        for what, values in (
            ("node_id", [n.node_id for n in self.nodes]),
            ("address", [n.address for n in self.nodes]),
            ("proxy_port", [n.proxy_port for n in self.nodes if n.proxy_port]),
        ):
            if len(set(values)) != len(values):
                raise ValueError(f"router nodes: duplicate {what} in {values}")
        self._by_address = {_resolve(*n.address): n.node_id for n in self.nodes}
        self._address = {n.node_id: _resolve(*n.address) for n in self.nodes}
        self._socks: dict[str, socket.socket] = {}
        self._fd_node: dict[int, str] = {}
        self._readiness = select.poll()
        self._queue = DeliveryQueue()
        self._refusals_logged: set[tuple[str, str, str]] = set()
        self._deaf: set[str] = set()
        """Nodes whose receiver failed (:meth:`silence`)."""
        self._mute: set[str] = set()
        """Nodes whose transmitter failed."""
        try:
            for node in self.nodes:
                sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                self._socks[node.node_id] = sock
                try:
                    sock.bind((bind_addr, node.proxy_port))
                except OSError as exc:
                    raise OSError(
                        exc.errno,
                        f"router: cannot bind UDP {bind_addr}:{node.proxy_port} (proxy of node "
                        f"{node.node_id}): {exc.strerror}",
                    ) from exc
                sock.setblocking(False)
                self._fd_node[sock.fileno()] = node.node_id
                self._readiness.register(sock.fileno(), select.POLLIN)
        except BaseException:
            self.close()
            raise

    def proxy_address(self, node_id: str) -> Address:
        """(host, port) other nodes send to in order to reach ``node_id``."""
        host, port = self._socks[node_id].getsockname()[:2]
        return (host, port)

    def silence(self, node_id: str, *, tx: bool, rx: bool) -> None:
        """From now on drop what ``node_id`` sends (``tx``) and what is sent to it (``rx``).

        Counted as :data:`FAULT` per pair. What it sent that is already in flight still
        arrives; what is in flight towards it is dropped on arrival.

        Raises:
            KeyError: no node has that id.
        """
        if node_id not in self._address:
            raise KeyError(f"router: no node {node_id!r} (nodes: {sorted(self._address)})")
        if tx:
            self._mute.add(node_id)
        if rx:
            self._deaf.add(node_id)

    def filenos(self) -> list[int]:
        """File descriptors of the proxy sockets (for a driver's readiness wait)."""
        return list(self._fd_node)

    @property
    def next_arrival_s(self) -> float:
        """Arrival time of the earliest datagram in flight, s (inf: none)."""
        return self._queue.next_arrival_s

    @property
    def in_flight(self) -> int:
        """Datagrams held now."""
        return len(self._queue)

    def poll(self, now_s: float) -> None:
        """Read every datagram that is ready, then send every one due by ``now_s``."""
        if not self._socks:
            return
        for fd, _ in self._readiness.poll(0):
            dst = self._fd_node.get(fd)
            if dst is not None:
                self._receive(now_s, dst)
        if self._queue.next_arrival_s <= now_s:
            for src, dst, data in self._queue.pop_due(now_s):
                self._forward(src, dst, data)

    def _receive(self, now_s: float, dst: str) -> None:
        sock = self._socks[dst]
        for _ in range(MAX_READS_PER_SOCKET):
            try:
                data, address = sock.recvfrom(MAX_DATAGRAM_BYTES)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # e.g. ICMP port unreachable reported on this socket
                log.debug("router: recvfrom on the proxy of %s failed: %s", dst, exc)
                continue
            src = self._by_address.get((address[0], address[1]))
            if src is None:
                unknown = self.stats.unknown_senders
                unknown[dst] = unknown.get(dst, 0) + 1
                if unknown[dst] == 1:
                    log.warning(
                        "router: datagram for %s from %s:%d, which is no node's address: "
                        "dropped (further ones counted)",
                        dst,
                        *address[:2],
                    )
                continue
            pair = self.stats.pair(src, dst)
            pair.received += 1
            pair.received_bytes += len(data)
            if src == dst:
                self._refuse(pair, src, dst, SELF, "a node sent to its own proxy port")
                continue
            if src in self._mute:
                pair.dropped[FAULT] = pair.dropped.get(FAULT, 0) + 1
                continue
            try:
                arrival, reason = self._submit(now_s, src, dst, len(data))
            except DatagramTooLargeError as exc:
                self._refuse(pair, src, dst, OVERSIZE, str(exc))
                continue
            except ValueError as exc:  # the network does not know a node
                self._refuse(pair, src, dst, REFUSED, str(exc))
                continue
            if arrival is None:
                key = reason.value if reason is not None else "unknown"
                pair.dropped[key] = pair.dropped.get(key, 0) + 1
                continue
            self._queue.push(arrival, (src, dst, data))

    def _refuse(self, pair: PairStats, src: str, dst: str, reason: str, why: str) -> None:
        """Count a datagram dropped before the network; log the first one of each kind."""
        pair.dropped[reason] = pair.dropped.get(reason, 0) + 1
        key = (src, dst, reason)
        level = logging.DEBUG if key in self._refusals_logged else logging.WARNING
        self._refusals_logged.add(key)
        log.log(level, "router: %s -> %s dropped (%s): %s", src, dst, reason, why)

    def _forward(self, src: str, dst: str, data: bytes) -> None:
        pair = self.stats.pair(src, dst)
        if dst in self._deaf:
            pair.dropped[FAULT] = pair.dropped.get(FAULT, 0) + 1
            return
        sock = self._socks.get(src)
        if sock is None:
            return
        try:
            sock.sendto(data, self._address[dst])
        except OSError as exc:
            pair.send_errors += 1
            log.debug("router: %s -> %s: sendto failed: %s", src, dst, exc)
            return
        pair.forwarded += 1
        pair.forwarded_bytes += len(data)

    def close(self) -> None:
        """Close the proxy sockets (what is in flight is lost). Safe to call twice."""
        for sock in self._socks.values():
            with contextlib.suppress(KeyError, ValueError, OSError):
                self._readiness.unregister(sock.fileno())
            sock.close()
        self._socks.clear()
        self._fd_node.clear()

    def __enter__(self) -> LinkRouter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class RouterThread:
    """Drives a :class:`LinkRouter` on wall time x ``speed`` in a thread (no physics).

    The clock starts at 0 s on :meth:`start`; the thread sleeps until a proxy socket is
    readable or the next datagram is due (at most ``max_wait_s`` wall seconds, which also
    bounds how long :meth:`stop` waits).
    """

    def __init__(self, router: LinkRouter, speed: float = 1.0, max_wait_s: float = 0.05) -> None:
        if not (math.isfinite(speed) and speed > 0):
            raise ValueError(f"speed must be > 0, got {speed}")
        if not max_wait_s > 0:
            raise ValueError(f"max_wait_s must be > 0, got {max_wait_s}")
        self.router = router
        self.speed = speed
        self._max_wait_s = max_wait_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0
        self.error: BaseException | None = None
        """What ended the thread early, if anything (also logged)."""

    @property
    def now_s(self) -> float:
        """The router's clock: wall seconds since start x speed."""
        return (time.monotonic() - self._t0) * self.speed

    def start(self) -> None:
        """Start the thread (once)."""
        if self._thread is not None:
            raise RuntimeError("the router thread was started already")
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="link-router", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        router = self.router
        waiter = select.poll()
        for fd in router.filenos():
            waiter.register(fd, select.POLLIN)
        try:
            while not self._stop.is_set():
                router.poll(self.now_s)
                wait_s = (router.next_arrival_s - self.now_s) / self.speed
                wait_s = min(max(wait_s, 0.0), self._max_wait_s)
                if wait_s > 0:
                    waiter.poll(wait_s * 1000.0)
        except BaseException as exc:  # a closed socket, a network bug: end, never hang
            self.error = exc
            log.exception("router thread stopped")

    def stop(self) -> None:
        """Stop the thread and wait for it (the router stays open: close it yourself)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()

    def __enter__(self) -> RouterThread:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
