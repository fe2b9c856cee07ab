"""One direction of a link, in simulation time: a transmitter queue, the medium, the receiver.

A datagram submitted at ``now_s`` waits behind the bytes already queued (drop-tail: it is dropped
when they and it exceed ``queue_bytes``), takes ``wire bytes x bits_per_byte / rate_bps`` on the
medium, may be lost there (it used its airtime all the same), and arrives ``latency`` after its
last bit. A link that is down drops what is submitted. Nothing here reads a clock or a socket: the
router (paced) and the in-process queue (lockstep) ask when a datagram arrives and hold it until
then, so both give the same deliveries for the same submissions.

Every random draw comes from the channel's own generator (seeded per link by the network), so the
same seed and the same traffic give the same drops and delays; random outages draw from a child
generator, so the up/down schedule depends on time only, not on the traffic.
"""

from __future__ import annotations

import bisect
import math
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import StrEnum
from operator import itemgetter

import numpy as np

from sitl.links.params import Jitter, LinkParams, LossModel

_BLOCK = 256
"""Random numbers drawn at a time (one numpy call per block instead of per datagram)."""
_ARRIVAL = itemgetter(0)
_ITEM = itemgetter(2)


class Drop(StrEnum):
    """Why a datagram did not arrive."""

    LOSS = "loss"
    """Lost on the medium (the loss model)."""
    RANGE = "range"
    """Lost to distance (beyond the link's range)."""
    QUEUE = "queue"
    """The transmitter's queue was full (drop-tail)."""
    DOWN = "down"
    """The link was down (an outage window or a random failure)."""
    COVERAGE = "coverage"
    """The node was outside the network's coverage."""
    NO_LINK = "no_link"
    """No link joins the two nodes."""
    FAULT = "fault"
    """The node's radio was faulted (a scenario's ``faults:``): it sends or hears nothing."""


class DatagramTooLargeError(ValueError):
    """A datagram exceeds the link's ``max_datagram_bytes`` (it is refused, never truncated)."""


@dataclass(slots=True)
class ChannelStats:
    """What crossed one direction of one link."""

    submitted: int = 0
    submitted_bytes: int = 0
    delivered: int = 0
    delivered_bytes: int = 0
    dropped: dict[str, int] = field(default_factory=dict)
    """Datagrams dropped, by :class:`Drop` value."""
    airtime_s: float = 0.0
    """Time the transmitter spent sending (lost datagrams included), s."""
    latencies_s: array = field(default_factory=lambda: array("d"))
    """Submit-to-arrival time of every delivered datagram, s (queueing + transmission + delay);
    a packed array of doubles (8 B per datagram)."""


class _Outages:
    """The up/down schedule: fixed windows plus an alternating renewal process.

    The renewal process's toggle times are drawn in order from the outage generator and kept,
    so the schedule depends on the seed only (not on when or how often it is asked).
    """

    def __init__(self, params: LinkParams, rng: np.random.Generator) -> None:
        self._windows = sorted(params.outages.windows_s)
        self._mtbf_s = params.outages.mtbf_s
        self._mttr_s = params.outages.mttr_s
        self._rng = rng
        self._toggles: list[float] = []
        """Times the random process flips (up -> down at even indexes), s."""
        self._drawn_to_s = float(rng.exponential(self._mtbf_s)) if self._mtbf_s > 0 else math.inf
        if self._mtbf_s > 0:
            self._toggles.append(self._drawn_to_s)

    def _draw_until(self, t_s: float) -> None:
        while self._drawn_to_s <= t_s:
            mean = self._mttr_s if len(self._toggles) % 2 == 1 else self._mtbf_s
            self._drawn_to_s += float(self._rng.exponential(mean))
            self._toggles.append(self._drawn_to_s)

    def is_up(self, now_s: float) -> bool:
        """Whether the link is up at ``now_s``."""
        if self._toggles:
            if now_s >= self._drawn_to_s:
                self._draw_until(now_s)
            if bisect.bisect_right(self._toggles, now_s) % 2 == 1:
                return False
        if not self._windows:
            return True
        return not any(start <= now_s < end for start, end in self._windows)

    def uptime_fraction(self, duration_s: float) -> float:
        """Share of [0, duration_s] the link was up (windows and random failures together)."""
        if duration_s <= 0.0:
            return 1.0
        down_periods = list(self._windows)
        if self._toggles:
            self._draw_until(duration_s)
            t = self._toggles
            down_periods += [(t[k], t[k + 1]) for k in range(0, len(t) - 1, 2)]
        intervals = sorted(
            (max(0.0, a), min(duration_s, b)) for a, b in down_periods if a < duration_s
        )
        down = 0.0
        end = 0.0
        for a, b in intervals:
            a = max(a, end)
            if b > a:
                down += b - a
                end = b
        return 1.0 - down / duration_s


class LinkChannel:
    """One direction of one link with its queue, loss, delay and outages.

    Args:
        params: the link's parameters.
        rng: this channel's generator (the network seeds one per directed link).
    """

    def __init__(self, params: LinkParams, rng: np.random.Generator) -> None:
        self.params = params
        self.stats = ChannelStats()
        self._rng = rng
        self._outages = _Outages(params, rng.spawn(1)[0])
        self._always_up = not params.outages.windows_s and params.outages.mtbf_s <= 0
        """No outage windows and no random failures: the schedule need not be asked."""
        self._bytes_per_s = params.rate_bps / params.bits_per_byte
        self._busy_until_s = 0.0
        self._last_arrival_s = 0.0
        self._last_now_s = -math.inf
        self._bad = False
        loss = params.loss
        self._bernoulli = loss.model is LossModel.BERNOULLI
        self._lossless = self._bernoulli and loss.mean_loss <= 0.0
        """No datagram is lost on the medium (and none draws a number for it)."""
        self._p_gb, self._p_bg = loss.transition_probabilities()
        self._range_from_m = params.range_m - params.range_width_m
        """Datagrams sent farther than this may be lost to range (and draw a number for it)."""
        latency = params.latency
        self._jittered = latency.jitter is not Jitter.NONE and latency.jitter_s != 0.0
        """Whether each delivered datagram draws a jitter."""
        self._uniforms: Iterator[float] = iter(())
        """The rest of the current block of uniform draws."""
        self._jitters: Iterator[float] = iter(())
        """The rest of the current block of jitter draws, s."""

    # -- random numbers, drawn in blocks -----------------------------------------------------

    # A block is kept as array("d") (8 bytes a number, as in numpy, not a float object each:
    # 80 nodes have 6320 channels, whose blocks must stay in cache) and read by an iterator.

    def _next_uniform(self) -> float:
        value = next(self._uniforms, None)
        if value is None:  # the block is used up: the next one
            self._uniforms = iter(array("d", self._rng.random(_BLOCK).tobytes()))
            value = next(self._uniforms)
        return value

    def _next_jitter(self) -> float:
        value = next(self._jitters, None)
        if value is None:
            latency = self.params.latency
            rng = self._rng
            if latency.jitter is Jitter.EXPONENTIAL:
                block = rng.exponential(latency.jitter_s, _BLOCK)
            elif latency.jitter is Jitter.LOGNORMAL:
                block = latency.jitter_s * np.exp(latency.sigma * rng.standard_normal(_BLOCK))
            else:
                block = rng.gamma(latency.shape, latency.jitter_s / latency.shape, _BLOCK)
            self._jitters = iter(array("d", block.tobytes()))
            value = next(self._jitters)
        return value

    def _lost(self) -> bool:
        loss = self.params.loss
        if self._bernoulli:
            return self._next_uniform() < loss.mean_loss
        # Gilbert-Elliott: the state moves once per datagram, then the state's loss applies.
        if self._bad:
            if self._next_uniform() < self._p_bg:
                self._bad = False
        elif self._next_uniform() < self._p_gb:
            self._bad = True
        return self._bad and (loss.loss_bad >= 1.0 or self._next_uniform() < loss.loss_bad)

    # -- the datagram path -------------------------------------------------------------------

    def is_up(self, now_s: float) -> bool:
        """Whether the link is up at ``now_s``."""
        return self._outages.is_up(now_s)

    def submit(
        self, now_s: float, payload_bytes: int, distance_m: float = 0.0
    ) -> tuple[float | None, Drop | None]:
        """Send one datagram at ``now_s``; returns (arrival time or None, why it was dropped).

        Raises:
            DatagramTooLargeError: ``payload_bytes`` exceeds ``max_datagram_bytes``.
        """
        params = self.params
        if payload_bytes > params.max_datagram_bytes:
            self._check_size(payload_bytes)
        if now_s < self._last_now_s:  # the simulation restarted: an empty link
            self._busy_until_s = now_s
            self._last_arrival_s = now_s
        self._last_now_s = now_s
        stats = self.stats
        stats.submitted += 1
        stats.submitted_bytes += payload_bytes
        if not self._always_up and not self._outages.is_up(now_s):
            return self._drop(Drop.DOWN)
        wire = payload_bytes + params.overhead_bytes
        start = self._busy_until_s if self._busy_until_s > now_s else now_s
        if (start - now_s) * self._bytes_per_s + wire > params.queue_bytes:
            return self._drop(Drop.QUEUE)
        airtime = wire / self._bytes_per_s
        end = start + airtime
        self._busy_until_s = end
        stats.airtime_s += airtime
        if not self._lossless and self._lost():
            return self._drop(Drop.LOSS)
        if distance_m > self._range_from_m:
            p_range = params.range_loss(distance_m)
            if p_range >= 1.0 or self._next_uniform() < p_range:
                return self._drop(Drop.RANGE)
        arrival = end + params.latency.base_s
        if self._jittered:
            arrival += self._next_jitter()
        if params.in_order and arrival < self._last_arrival_s:
            arrival = self._last_arrival_s
        self._last_arrival_s = arrival
        stats.delivered += 1
        stats.delivered_bytes += payload_bytes
        stats.latencies_s.append(arrival - now_s)
        return arrival, None

    def refuse(self, reason: Drop, payload_bytes: int = 0) -> tuple[None, Drop]:
        """Count a datagram dropped before reaching the medium (no coverage, no link).

        Raises:
            DatagramTooLargeError: ``payload_bytes`` exceeds ``max_datagram_bytes``.
        """
        self._check_size(payload_bytes)
        self.stats.submitted += 1
        self.stats.submitted_bytes += payload_bytes
        return self._drop(reason)

    def uptime_fraction(self, duration_s: float) -> float:
        """Share of [0, duration_s] the link was up (outage windows and random failures)."""
        return self._outages.uptime_fraction(duration_s)

    def _check_size(self, payload_bytes: int) -> None:
        if payload_bytes > self.params.max_datagram_bytes:
            raise DatagramTooLargeError(
                f"datagram of {payload_bytes} B exceeds the {self.params.kind} link's limit of "
                f"{self.params.max_datagram_bytes} B"
            )

    def _drop(self, reason: Drop) -> tuple[None, Drop]:
        dropped = self.stats.dropped
        dropped[reason.value] = dropped.get(reason.value, 0) + 1
        return None, reason


class DeliveryQueue:
    """Datagrams in flight, released in order of arrival time (ties: in order of submission).

    The lockstep transport: ``push`` what the channel accepted, ``pop_due(now_s)`` each step.
    Entries are appended and sorted by (arrival, submission) only when one arrived out of
    order: a node's datagrams of one step, pushed together, are released with one sort and one
    slice instead of a heap operation each.
    """

    def __init__(self) -> None:
        self._items: list[tuple[float, int, object]] = []
        """(arrival s, submission number, item); in order when ``_sorted``."""
        self._sorted = True
        self._seq = 0

    def __len__(self) -> int:
        return len(self._items)

    def push(self, arrival_s: float, item: object) -> None:
        """Hold ``item`` until simulation time ``arrival_s``."""
        items = self._items
        if self._sorted and items and arrival_s < items[-1][0]:
            self._sorted = False
        items.append((arrival_s, self._seq, item))
        self._seq += 1

    def _in_order(self) -> list[tuple[float, int, object]]:
        if not self._sorted:
            self._items.sort()  # (arrival, submission) pairs are unique: items never compared
            self._sorted = True
        return self._items

    @property
    def next_arrival_s(self) -> float:
        """Arrival time of the earliest item, s (inf when empty)."""
        return self._in_order()[0][0] if self._items else math.inf

    def pop_due(self, now_s: float) -> list[object]:
        """Every item whose arrival time is <= ``now_s``, earliest first."""
        if not self._items:
            return []
        items = self._in_order()
        k = bisect.bisect_right(items, now_s, key=_ARRIVAL)
        due = items[:k]
        del items[:k]
        return list(map(_ITEM, due))

    def clear(self) -> list[object]:
        """Remove and return everything in flight (earliest first)."""
        out = list(map(_ITEM, self._in_order()))
        self._items.clear()
        return out
