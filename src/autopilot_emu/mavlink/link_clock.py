"""The simulation time of the poll an endpoint is in, shared by the parts of the endpoint."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class LinkClock:
    """Simulation time of the current poll (set by the endpoint at the start of each poll).

    The sender stamps the tlog and the modelled link with it, the receiver the frames it logs,
    the handlers what they hand the vehicle; streams are keyed by it.
    """

    now_s: float = 0.0
    """Simulation time, s."""
    now_us: int = 0
    """The same, rounded to microseconds."""
