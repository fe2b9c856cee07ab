"""A MAVLink endpoint's traffic held in two link channels: the modelled UART or radio.

An emulated autopilot talks UDP to its companion and ground station, but the real one talks
through a 921600-baud UART and a 57600-baud SiK radio. :class:`MavlinkLinkShaper` implements
the endpoint's ``LinkShaper`` seam (``autopilot_emu.mavlink.shaping``, matched by duck typing:
``sitl`` does not import the autopilot): every frame the vehicle transmits is submitted to the
``from_vehicle`` channel, every datagram it receives to the ``to_vehicle`` channel, and each is
released when the channel says it arrived. A serial link is byte-level: ``bits_per_byte`` 10
(8N1) and no per-datagram overhead make 921600 baud carry exactly 92160 B/s, the real MAVLink
budget of a TELEM port. A frame that does not fit the transmit queue is dropped and counted, as
PX4 drops a message when its serial TX buffer lacks room. Pure: no sockets, no clock.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from sitl.links.channel import DatagramTooLargeError, DeliveryQueue, LinkChannel

log = logging.getLogger(__name__)

OVERSIZE = "oversize"
"""Drop reason of a datagram above the link's ``max_datagram_bytes`` (refused, not truncated)."""


@dataclass(slots=True)
class DirectionStats:
    """What one direction of a shaped MAVLink link carried (a snapshot)."""

    frames: int = 0
    """Frames (vehicle -> peers) or datagrams (peers -> vehicle) handed to the link."""
    bytes: int = 0
    """Their bytes."""
    delivered: int = 0
    """Of those, released at their arrival time so far."""
    delivered_bytes: int = 0
    held: int = 0
    """In flight now (accepted, not yet arrived)."""
    dropped: dict[str, int] = field(default_factory=dict)
    """Dropped, by reason (``queue``, ``loss``, ``down``, ``oversize``, ...)."""
    airtime_s: float = 0.0
    """Time the transmitter spent sending, s (its load = airtime / elapsed time)."""

    @property
    def dropped_total(self) -> int:
        """All drops, whatever the reason."""
        return sum(self.dropped.values())


@dataclass(frozen=True, slots=True)
class ShaperStats:
    """Both directions of one shaped link."""

    kind: str
    """The link model (``uart``, ``sik``, ...)."""
    to_vehicle: DirectionStats
    from_vehicle: DirectionStats


class _Direction:
    """One channel and its delivery queue, with counts of what was handed over."""

    def __init__(self, channel: LinkChannel, what: str) -> None:
        self.channel = channel
        self.queue = DeliveryQueue()
        self.what = what
        self.frames = 0
        self.bytes = 0
        self.delivered = 0
        self.delivered_bytes = 0
        self.oversize = 0

    def submit(self, now_s: float, item: object, size: int) -> None:
        self.frames += 1
        self.bytes += size
        try:
            arrival, _ = self.channel.submit(now_s, size)
        except DatagramTooLargeError as exc:
            self.oversize += 1
            if self.oversize == 1:
                log.warning("%s dropped: %s (further ones counted, not logged)", self.what, exc)
            return
        if arrival is not None:
            self.queue.push(arrival, item)

    def pop_due(self, now_s: float) -> list:
        due = self.queue.pop_due(now_s)
        for item in due:
            self.delivered += 1
            self.delivered_bytes += len(item if isinstance(item, bytes) else item[0])
        return due

    def stats(self) -> DirectionStats:
        dropped = dict(self.channel.stats.dropped)
        if self.oversize:
            dropped[OVERSIZE] = self.oversize
        return DirectionStats(
            frames=self.frames,
            bytes=self.bytes,
            delivered=self.delivered,
            delivered_bytes=self.delivered_bytes,
            held=len(self.queue),
            dropped=dropped,
            airtime_s=self.channel.stats.airtime_s,
        )


class MavlinkLinkShaper:
    """Holds a MAVLink endpoint's frames and datagrams until their modelled arrival.

    Args:
        to_vehicle: the channel from the peers (companion, ground station) to the autopilot.
        from_vehicle: the channel from the autopilot to its peers.

    Simulation time never goes back within a run; if it does (a restarted simulation), what
    is in flight is discarded, as a link that was reset.
    """

    def __init__(self, to_vehicle: LinkChannel, from_vehicle: LinkChannel) -> None:
        self._in = _Direction(to_vehicle, f"datagram to the vehicle over {to_vehicle.params.kind}")
        self._out = _Direction(
            from_vehicle, f"frame from the vehicle over {from_vehicle.params.kind}"
        )
        self._last_now_s = -math.inf

    @property
    def kind(self) -> str:
        """The link model of the vehicle's transmit direction (``uart``, ``sik``, ...)."""
        return self._out.channel.params.kind

    def _clock(self, now_s: float) -> None:
        if now_s < self._last_now_s:
            self._in.queue.clear()
            self._out.queue.clear()
        self._last_now_s = now_s

    def outbound(self, now_s: float, frame: bytes) -> None:
        """Submit a frame the vehicle transmits at ``now_s``."""
        self._clock(now_s)
        self._out.submit(now_s, frame, len(frame))

    def inbound(self, now_s: float, data: bytes, address: tuple[str, int]) -> None:
        """Submit a datagram received from ``address`` at ``now_s``."""
        self._clock(now_s)
        self._in.submit(now_s, (data, address), len(data))

    def due_outbound(self, now_s: float) -> list[bytes]:
        """Frames arrived at the peers' end by ``now_s``, earliest first."""
        self._clock(now_s)
        return self._out.pop_due(now_s)

    def due_inbound(self, now_s: float) -> list[tuple[bytes, tuple[str, int]]]:
        """Datagrams arrived at the vehicle by ``now_s``, earliest first, with their senders."""
        self._clock(now_s)
        return self._in.pop_due(now_s)

    @property
    def next_due_s(self) -> float:
        """Earliest arrival held in either direction, s (inf: nothing in flight)."""
        a = self._in.queue.next_arrival_s
        b = self._out.queue.next_arrival_s
        return a if a < b else b

    @property
    def stats(self) -> ShaperStats:
        """Counts of both directions now."""
        return ShaperStats(self.kind, self._in.stats(), self._out.stats())
