"""The seam that puts a MAVLink endpoint behind a modelled link (a UART, a radio).

A real PX4 reaches its companion through a 921600-baud UART and its ground station through a
57600-baud radio; both delay, throttle and sometimes drop frames. The endpoint knows nothing of
link models (``autopilot_emu`` imports nothing of the simulator): it hands each frame it
transmits and each datagram it receives to a :class:`LinkShaper`, and sends or parses them only
when the shaper says they are due, at the simulation time of its polls. The harness supplies
the implementation (``sitl.links.shaper.MavlinkLinkShaper``); ``EndpointConfig.shaper = None``
keeps the endpoint as it was, byte for byte.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

Address = tuple[str, int]
"""A UDP (host, port) as ``recvfrom`` reports it."""


@runtime_checkable
class LinkShaper(Protocol):
    """Holds one endpoint's traffic in both directions until its modelled delivery time.

    Times are simulation seconds and never go backwards within a run. A frame or datagram the
    link drops (full transmit queue, loss, outage) is simply never due; the shaper counts it.
    """

    def outbound(self, now_s: float, frame: bytes) -> None:
        """Take a frame the vehicle transmits at ``now_s`` (towards its peers)."""
        ...

    def inbound(self, now_s: float, data: bytes, address: Address) -> None:
        """Take a datagram received at ``now_s`` from ``address`` (towards the vehicle)."""
        ...

    def due_outbound(self, now_s: float) -> list[bytes]:
        """Frames that have crossed the link by ``now_s``, in arrival order."""
        ...

    def due_inbound(self, now_s: float) -> list[tuple[bytes, Address]]:
        """Datagrams that have crossed the link by ``now_s``, in arrival order, with senders."""
        ...

    @property
    def next_due_s(self) -> float:
        """Earliest arrival time held in either direction, s (inf when nothing is held)."""
        ...
