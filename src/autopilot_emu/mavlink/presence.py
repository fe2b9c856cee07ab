"""What a link knows of the programs at its other end: how far they have read, when they last beat.

A MAVLink link sees two signs of a live peer. A PING request (target 0/0) that the link sends
carries the simulation time in ``time_usec``; a peer that answers it (MAVSDK's ``mavsdk_server``
does, as PX4 answers ours) echoes that time back, which says the peer has read everything the
link sent up to then. A ground station's HEARTBEAT says it is there (PX4's data-link-loss check
counts only those, :mod:`autopilot_emu.failsafe`). A lockstep simulation (``harness.lockstep``)
reads both to never run away from a companion computer that is slower than the simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

NEVER = -math.inf
"""Time of an event that has not happened."""


@dataclass
class PeerPresence:
    """The latest signs of life from a link's peers, in simulation and in wall time."""

    echo_s: float = NEVER
    """Latest simulation time a peer echoed in its answer to one of our PING requests, s."""
    echo_wall_s: float = NEVER
    """Monotonic wall time that echo arrived, s."""
    heartbeat_s: float = NEVER
    """Simulation time of the last ground-station HEARTBEAT, s."""
    heartbeat_wall_s: float = NEVER
    """Monotonic wall time it arrived, s."""

    def echoed(self, echo_s: float, now_s: float, wall_s: float) -> None:
        """A peer answered our PING of ``echo_s`` (ignored unless it is a time we have sent)."""
        if echo_s <= now_s and echo_s > self.echo_s:
            self.echo_s = echo_s
            self.echo_wall_s = wall_s

    def heartbeat(self, now_s: float, wall_s: float) -> None:
        """A ground station's HEARTBEAT arrived."""
        self.heartbeat_s = now_s
        self.heartbeat_wall_s = wall_s
