"""A messaging node: send, request/reply with retries, handlers, records; poll-driven.

``Node`` is synchronous and owns no thread: the caller calls ``poll()`` (a lockstep harness
once per step, ``AsyncNode`` whenever the socket is readable or a retry is due). Time is the
injected ``clock`` (simulated seconds under swarmsitl), so retries and timeouts happen in
simulation time.

Request semantics: ``request`` sends a "request" envelope and returns a ``PendingRequest``.
If no reply has arrived ``timeout_s`` after a copy was sent, the same msg_id is sent again
with ``attempt + 1``, up to ``retries`` times; after the last copy's timeout the request
fails with ``RequestTimeout``. The receiver runs its handler once per (sender, msg_id) and
answers retransmissions from a bounded reply cache, so a request is executed at most once
(while its entry is in the cache) and answered at least once if any copy and reply arrive.
"""

from __future__ import annotations

import json
from collections import OrderedDict, deque
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from companion.net.config import NetConfig, link_class
from companion.net.envelope import (
    CATEGORIES,
    Envelope,
    EnvelopeError,
    decode,
    encode,
    encode_fanout,
)
from companion.net.stats import NodeStats, PeerStats, TaskRecord
from companion.net.transport import Transport

Handler = Callable[[Envelope], Any]
"""Called with each message/request of its topic; for a request, a non-None return is the reply
body."""
REPLY_CACHE_SIZE = 1024
"""Requests remembered per node for duplicate suppression (oldest forgotten first)."""
REPLY_CACHE_WINDOW_S = 60.0
"""Age after which a remembered request is forgotten (a restarted sender reuses msg_ids), s."""


class RequestTimeout(TimeoutError):
    """A request got no reply after its last retry."""


@dataclass
class PendingRequest:
    """A request in flight; ``done`` once it has a ``reply`` or an ``error``."""

    dst: str
    """Node asked."""
    topic: str
    """Request topic."""
    msg_id: int
    """Id shared by all copies of the request."""
    timeout_s: float
    """Wait per copy before retransmitting, s."""
    retries: int
    """Retransmissions allowed after the first copy."""
    attempts: int = 0
    """Copies sent so far."""
    deadline_s: float = 0.0
    """Clock time at which the last copy times out, s."""
    sent_s: dict[int, float] = field(default_factory=dict)
    """Clock time each attempt was sent, s."""
    reply: Envelope | None = None
    """The reply, once received."""
    error: RequestTimeout | None = None
    """Set when the request failed after its last retry."""
    rtt_s: float | None = None
    """Round trip of the answered copy (reply echoes its attempt), s."""

    @property
    def done(self) -> bool:
        """True once replied to or timed out."""
        return self.reply is not None or self.error is not None


class Node:
    """One messaging node (see the module docstring)."""

    def __init__(
        self,
        node_id: str,
        config: NetConfig,
        transport: Transport,
        clock: Callable[[], float],
    ) -> None:
        if node_id not in config.nodes:
            raise ValueError(f"node_id: {node_id!r} is not a node of the configuration")
        self.node_id = node_id
        self.config = config
        self.role = config.nodes[node_id].role
        self.transport = transport
        self.clock = clock
        self.stats = NodeStats(node_id, self.role)
        self._handlers: dict[str, Handler] = {}
        self._next_id = 0
        self._pending: dict[int, PendingRequest] = {}
        self._request_envs: dict[int, Envelope] = {}
        self._seen: OrderedDict[tuple[str, int], tuple[float, Envelope | None, bool]] = (
            OrderedDict()
        )
        """Requests seen per (sender, msg_id): when, the reply sent (None: none yet), and
        whether a handler took it (False: it went to :meth:`poll`'s caller)."""
        self._inbox: deque[bytes] = deque()
        self._unconsumed: list[Envelope] = []

    # --- sending -------------------------------------------------------------------------

    def send(self, dst: str, topic: str, body: Any, category: str = "data") -> int:
        """Send a one-way message to ``dst``; return its msg_id."""
        env = self._envelope(dst, "msg", topic, body, category)
        self._transmit(dst, category, encode(env))
        return env.msg_id

    def send_group(self, group: str, topic: str, body: Any, category: str = "data") -> int:
        """Send to every other member of ``group`` (one unicast each); return the count."""
        if group not in self.config.groups:
            raise ValueError(f"group: unknown group {group!r}")
        members = [n for n in self.config.members(group) if n != self.node_id]
        return self._send_many(members, topic, body, category)

    def broadcast(self, topic: str, body: Any, category: str = "data") -> int:
        """Send to every other node (one unicast each); return the count."""
        others = [n for n in self.config.nodes if n != self.node_id]
        return self._send_many(others, topic, body, category)

    def request(
        self,
        dst: str,
        topic: str,
        body: Any,
        timeout_s: float = 1.0,
        retries: int = 3,
        category: str = "control",
    ) -> PendingRequest:
        """Send a request; poll() retransmits it and fills in the reply or the error."""
        if timeout_s <= 0:
            raise ValueError(f"timeout_s: must be > 0, got {timeout_s}")
        if retries < 0:
            raise ValueError(f"retries: must be >= 0, got {retries}")
        env = self._envelope(dst, "request", topic, body, category)
        data = encode(env)
        pending = PendingRequest(dst, topic, env.msg_id, timeout_s, retries)
        self._pending[env.msg_id] = pending
        self._request_envs[env.msg_id] = env
        self._send_attempt(pending, env, data)
        return pending

    def cancel(self, pending: PendingRequest) -> None:
        """Stop retransmitting ``pending`` (a late reply is then counted as late)."""
        if self._pending.get(pending.msg_id) is pending:
            self._forget(pending)

    def reply(self, request: Envelope, body: Any, category: str = "control") -> None:
        """Answer ``request`` (from a handler's caller, possibly later than the handler)."""
        if request.kind != "request":
            raise ValueError(f"request: envelope is a {request.kind!r}, not a request")
        env = self._envelope(request.src, "reply", request.topic, body, category)
        env.reply_to = request.msg_id
        env.attempt = request.attempt
        data = encode(env)
        self._seen[(request.src, request.msg_id)] = (env.sent_s, env, True)
        self._transmit(env.dst, env.category, data)

    # --- receiving -----------------------------------------------------------------------

    def on(self, topic: str, handler: Handler) -> None:
        """Run ``handler(env)`` for messages and requests of ``topic`` (replaces any other)."""
        self._handlers[topic] = handler

    def poll(self) -> list[Envelope]:
        """Receive, dispatch, retransmit and expire; return messages no handler consumed.

        Malformed, misaddressed and late datagrams are counted and dropped. An exception
        raised by a handler propagates; the datagrams after it wait for the next poll.
        """
        inbox = self._inbox
        inbox.extend(self.transport.receive())
        accept, dispatch = self._accept, self._dispatch
        while inbox:
            env = accept(inbox.popleft())
            if env is not None:
                dispatch(env)
        self._expire()
        out, self._unconsumed = self._unconsumed, []
        return out

    def next_deadline_s(self) -> float | None:
        """Clock time of the next retransmission or timeout, or None if nothing is pending."""
        return min((p.deadline_s for p in self._pending.values()), default=None)

    # --- records -------------------------------------------------------------------------

    @contextmanager
    def task(self, name: str) -> Iterator[None]:
        """Record the interval of the ``with`` block as task ``name`` in the stats."""
        start_s = self.clock()
        try:
            yield
        finally:
            self.stats.tasks.append(TaskRecord(name, start_s, self.clock()))

    def records(self) -> dict[str, Any]:
        """``stats.to_dict()`` plus the transport's send and receive errors."""
        out = self.stats.to_dict()
        out["send_errors"] = getattr(self.transport, "send_errors", 0)
        out["receive_errors"] = getattr(self.transport, "receive_errors", 0)
        return out

    def write_records(self, path: str | Path) -> None:
        """Write ``records()`` as JSON (the harness collects every node's file)."""
        Path(path).write_text(json.dumps(self.records(), indent=1))

    def close(self) -> None:
        """Close the transport."""
        self.transport.close()

    # --- internals -----------------------------------------------------------------------

    def _envelope(self, dst: str, kind: str, topic: str, body: Any, category: str) -> Envelope:
        if dst not in self.config.nodes:
            raise ValueError(f"dst: unknown node {dst!r}")
        if dst == self.node_id:
            raise ValueError(f"dst: node {dst!r} does not send to itself")
        if category not in CATEGORIES:
            raise ValueError(f"category: {category!r}, expected one of {CATEGORIES}")
        self._next_id += 1
        return Envelope(
            self.node_id, dst, kind, topic, self._next_id, None, category, self.clock(), 1, body
        )

    def _send_many(self, dsts: list[str], topic: str, body: Any, category: str) -> int:
        """One unicast to each of ``dsts`` (other nodes of the configuration), msg_ids in turn."""
        if not dsts:
            return 0
        if category not in CATEGORIES:
            raise ValueError(f"category: {category!r}, expected one of {CATEGORIES}")
        first = self._next_id + 1
        self._next_id += len(dsts)
        template = Envelope(
            self.node_id, "", "msg", topic, first, None, category, self.clock(), 1, body
        )
        datagrams = encode_fanout(template, dsts)  # all or nothing: sizes are checked first
        for dst, data in zip(dsts, datagrams, strict=True):
            self._transmit(dst, category, data)
        return len(dsts)

    def _transmit(self, dst: str, category: str, data: bytes) -> None:
        self.transport.send(dst, data)  # may raise (a datagram above a link's limit)
        traffic = (self.stats.peers.get(dst) or self._record(dst)).sent[category]
        traffic.messages += 1
        traffic.bytes += len(data)

    def _record(self, peer: str) -> PeerStats:
        """The stats record of ``peer``, created with its link class on first use.

        The hot paths try ``self.stats.peers.get(peer)`` first and call this only on a miss.
        """
        record = self.stats.peers.get(peer)
        if record is None:
            record = self.stats.peer(peer, self._link(peer))
        return record

    def _send_attempt(self, pending: PendingRequest, env: Envelope, data: bytes) -> None:
        pending.attempts = env.attempt
        pending.sent_s[env.attempt] = env.sent_s
        pending.deadline_s = env.sent_s + pending.timeout_s
        self._transmit(env.dst, env.category, data)

    def _link(self, peer: str) -> str:
        return link_class(self.role, self.config.nodes[peer].role)

    def _accept(self, data: bytes) -> Envelope | None:
        try:
            env = decode(data)
        except EnvelopeError:
            self.stats.malformed += 1
            return None
        src = env.src
        if env.dst != self.node_id or src not in self.config.nodes:
            self.stats.misaddressed += 1
            return None
        record = self.stats.peers.get(src) or self._record(src)
        category = env.category
        traffic = record.received[category]
        traffic.messages += 1
        traffic.bytes += len(data)
        record.latency_s[category].append(self.clock() - env.sent_s)
        return env

    def _dispatch(self, env: Envelope) -> None:
        if env.kind == "reply":
            self._match_reply(env)
            return
        if env.kind == "request" and self._is_duplicate(env):
            return
        handler = self._handlers.get(env.topic)
        if handler is None:
            self._unconsumed.append(env)
            return
        body = handler(env)
        if env.kind == "request" and body is not None:
            self.reply(env, body)

    def _is_duplicate(self, env: Envelope) -> bool:
        now = self.clock()
        key = (env.src, env.msg_id)
        entry = self._seen.get(key)
        handled = env.topic in self._handlers
        if entry is not None and now - entry[0] <= REPLY_CACHE_WINDOW_S:
            seen_s, cached, was_handled = entry
            if cached is None and not was_handled and handled:
                # Its first copy came before the topic had a handler (a node still starting)
                # and nobody answered it: the handler has not run for it yet, so it runs now.
                self._seen[key] = (seen_s, None, True)
                return False
            self.stats.duplicate_requests += 1
            if cached is not None:
                again = replace(cached, attempt=env.attempt, sent_s=now)
                self._transmit(again.dst, again.category, encode(again))
            return True
        self._seen[key] = (now, None, handled)
        self._seen.move_to_end(key)
        while len(self._seen) > REPLY_CACHE_SIZE:
            self._seen.popitem(last=False)
        return False

    def _match_reply(self, env: Envelope) -> None:
        pending = self._pending.get(env.reply_to) if env.reply_to is not None else None
        if pending is None or pending.dst != env.src:
            self.stats.late_replies += 1
            return
        now = self.clock()
        pending.reply = env
        pending.rtt_s = now - pending.sent_s.get(env.attempt, pending.sent_s[1])
        self._record(env.src).rtt_s.append(pending.rtt_s)
        self._forget(pending)

    def _expire(self) -> None:
        now = self.clock()
        for pending in [p for p in self._pending.values() if now >= p.deadline_s]:
            record = self._record(pending.dst)
            if pending.attempts <= pending.retries:
                first = self._request_envs[pending.msg_id]
                env = replace(first, attempt=pending.attempts + 1, sent_s=now, category="control")
                record.retries += 1
                self._send_attempt(pending, env, encode(env))
            else:
                record.timeouts += 1
                pending.error = RequestTimeout(
                    f"request {pending.topic!r} to {pending.dst} (msg_id {pending.msg_id}): "
                    f"no reply after {pending.attempts} copies, {pending.timeout_s} s each"
                )
                self._forget(pending)

    def _forget(self, pending: PendingRequest) -> None:
        del self._pending[pending.msg_id]
        del self._request_envs[pending.msg_id]
