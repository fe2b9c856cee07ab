"""asyncio front end of ``Node`` for companion programs (MAVSDK programs are asyncio).

The one line a companion program writes::

    node = AsyncNode.from_env()          # SWARMSITL_NET (YAML path), SWARMSITL_NODE (id)
    reply = await node.request("cloud", "plan", {"area": 3})
    async for env in node.messages(): ...

The core is polled when its UDP socket is readable (``loop.add_reader``) and on a timer for
retries (and, for a transport without a descriptor, every ``poll_interval_s``). Timeouts are
in simulated seconds through ``companion.clock`` (honours ``SWARMSITL_SPEED``).
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import AsyncIterator
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Any

from companion import clock
from companion.net.config import NetConfig
from companion.net.envelope import Envelope
from companion.net.node import Handler, Node, PendingRequest
from companion.net.stats import NodeStats
from companion.net.transport import UdpTransport

_log = logging.getLogger(__name__)


class AsyncNode:
    """A ``Node`` driven by the running asyncio loop."""

    def __init__(self, node: Node, poll_interval_s: float = 0.05) -> None:
        if poll_interval_s <= 0:
            raise ValueError(f"poll_interval_s: must be > 0, got {poll_interval_s}")
        self.node = node
        self.poll_interval_s = poll_interval_s
        """Polling period when the transport has no descriptor, simulated s."""
        self._loop: asyncio.AbstractEventLoop | None = None
        self._fd: int | None = None
        self._timer: asyncio.TimerHandle | None = None
        self._queue: asyncio.Queue[Envelope] | None = None
        self._waiters: dict[int, tuple[PendingRequest, asyncio.Future[Envelope]]] = {}
        self._closed = False

    @classmethod
    def from_env(cls) -> AsyncNode:
        """Build a UDP node from ``SWARMSITL_NET`` and ``SWARMSITL_NODE``, on companion time."""
        config, node_id = NetConfig.from_env()
        return cls(Node(node_id, config, UdpTransport(config, node_id), clock.now_s))

    @property
    def node_id(self) -> str:
        """This node's id."""
        return self.node.node_id

    @property
    def stats(self) -> NodeStats:
        """The core's records."""
        return self.node.stats

    # --- delegated, synchronous ----------------------------------------------------------

    def send(self, dst: str, topic: str, body: Any, category: str = "data") -> int:
        """Send a one-way message (see ``Node.send``)."""
        return self.node.send(dst, topic, body, category)

    def send_group(self, group: str, topic: str, body: Any, category: str = "data") -> int:
        """Send to every other member of a group (see ``Node.send_group``)."""
        return self.node.send_group(group, topic, body, category)

    def broadcast(self, topic: str, body: Any, category: str = "data") -> int:
        """Send to every other node (see ``Node.broadcast``)."""
        return self.node.broadcast(topic, body, category)

    def on(self, topic: str, handler: Handler) -> None:
        """Register a handler (see ``Node.on``); call ``start()`` or await something to serve."""
        self.node.on(topic, handler)

    def reply(self, request: Envelope, body: Any, category: str = "control") -> None:
        """Answer a request later (see ``Node.reply``)."""
        self.node.reply(request, body, category)

    def task(self, name: str) -> AbstractContextManager[None]:
        """Record a task interval (see ``Node.task``)."""
        return self.node.task(name)

    def write_records(self, path: str | Path) -> None:
        """Write the node's records as JSON (see ``Node.write_records``)."""
        self.node.write_records(path)

    # --- asynchronous --------------------------------------------------------------------

    def start(self) -> None:
        """Start polling on the running loop (idempotent; the async methods call it)."""
        if self._loop is not None:
            return
        if self._closed:
            raise RuntimeError("AsyncNode is closed")
        self._loop = asyncio.get_running_loop()
        self._queue = asyncio.Queue()
        self._fd = self.node.transport.fileno()
        if self._fd is not None:
            self._loop.add_reader(self._fd, self._pump)
        self._pump()

    async def request(
        self,
        dst: str,
        topic: str,
        body: Any,
        timeout_s: float = 1.0,
        retries: int = 3,
        category: str = "control",
    ) -> Envelope:
        """Send a request and return its reply.

        Raises:
            RequestTimeout: no reply after ``retries`` retransmissions (simulated seconds).
        """
        self.start()
        assert self._loop is not None
        pending = self.node.request(dst, topic, body, timeout_s, retries, category)
        future: asyncio.Future[Envelope] = self._loop.create_future()
        self._waiters[pending.msg_id] = (pending, future)
        self._schedule()
        try:
            return await future
        finally:
            self._waiters.pop(pending.msg_id, None)
            if not pending.done:  # the caller was cancelled: stop the retransmissions
                self.node.cancel(pending)

    async def recv(self, timeout_s: float | None = None) -> Envelope:
        """Next message no handler consumed.

        Raises:
            TimeoutError: none within ``timeout_s`` simulated seconds.
        """
        self.start()
        assert self._queue is not None
        if timeout_s is None:
            return await self._queue.get()
        return await asyncio.wait_for(self._queue.get(), timeout_s / clock.speed_factor())

    async def messages(self) -> AsyncIterator[Envelope]:
        """Every message no handler consumed, as it arrives."""
        while True:
            yield await self.recv()

    def close(self) -> None:
        """Stop polling, fail waiting requests with CancelledError and close the transport."""
        if self._closed:
            return
        self._closed = True
        if self._loop is not None and self._fd is not None:
            self._loop.remove_reader(self._fd)
        if self._timer is not None:
            self._timer.cancel()
        for _, future in self._waiters.values():
            future.cancel()
        self.node.close()

    async def __aenter__(self) -> AsyncNode:
        self.start()
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()

    # --- internals -----------------------------------------------------------------------

    def _pump(self) -> None:
        if self._closed:
            return
        assert self._queue is not None
        try:
            for env in self.node.poll():
                self._queue.put_nowait(env)
        except Exception:  # a handler's bug must not stop the node; it is logged
            _log.exception("message handler of node %s failed", self.node_id)
            if self._loop is not None:
                self._loop.call_soon(self._pump)  # the datagrams after it wait in the core
        for pending, future in self._waiters.values():
            if pending.done and not future.done():
                if pending.reply is not None:
                    future.set_result(pending.reply)
                else:
                    assert pending.error is not None
                    future.set_exception(pending.error)
        self._schedule()

    def _schedule(self) -> None:
        if self._loop is None or self._closed:
            return
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        delay_s: float | None = None
        deadline_s = self.node.next_deadline_s()
        if deadline_s is not None:
            delay_s = max(0.0, deadline_s - self.node.clock())
        if self._fd is None:  # nothing wakes the loop on arrival: poll periodically
            delay_s = min(delay_s if delay_s is not None else math.inf, self.poll_interval_s)
        if delay_s is not None:
            self._timer = self._loop.call_later(delay_s / clock.speed_factor(), self._pump)
