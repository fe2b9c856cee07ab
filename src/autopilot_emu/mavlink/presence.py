"""What a link knows of the programs at its other end: how far they have read, when they last beat.

A MAVLink link sees two signs of a live peer. A PING request (target 0/0) that the link sends
carries the simulation time in ``time_usec``; a peer that answers it (MAVSDK's ``mavsdk_server``
does, as PX4 answers ours) echoes that time back, which says the peer has read everything the
link sent up to then. A ground station's HEARTBEAT says it is there (PX4's data-link-loss check
counts only those, :mod:`autopilot_emu.failsafe`). A lockstep simulation (``harness.run.lockstep``)
reads both to never run away from a companion computer that is slower than the simulation.
:class:`PresenceHandler` sends a link's PING requests and handles the HEARTBEAT, PING and TIMESYNC
it receives.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import messages
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.vehicle_port import VehiclePort

Send = Callable[[mavlink2.MAVLink_message], None]

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


class PresenceHandler:
    """One link's PING requests, and what it makes of the peers' HEARTBEAT, PING and TIMESYNC.

    Args:
        vehicle: told of every ground-station HEARTBEAT (data-link-loss failsafe).
        sysid: our system id.
        compid: our component id.
        ping_period_s: how often to send a PING request, simulated s; 0: never.
        send: sends one message to every peer.
        clock: simulation time of the poll.
        wall_clock_s: monotonic wall clock (when echoes and heartbeats arrived).
    """

    def __init__(
        self,
        vehicle: VehiclePort,
        sysid: int,
        compid: int,
        ping_period_s: float,
        send: Send,
        clock: LinkClock,
        wall_clock_s: Callable[[], float],
    ) -> None:
        self._vehicle = vehicle
        self._sysid = sysid
        self._compid = compid
        self._send = send
        self._clock = clock
        self._wall_clock_s = wall_clock_s
        self.presence = PeerPresence()
        """The peers' latest PING echoes and ground-station HEARTBEATs."""
        self._ping_period_us = round(ping_period_s * 1e6)
        self.next_ping_us = 0 if self._ping_period_us > 0 else 2**62
        """Simulation time of our next PING request, us."""
        self._ping_seq = 0

    def send_ping(self, now_us: int) -> None:
        """Send a PING request (target 0/0, ``time_usec`` = now) and schedule the next."""
        self.next_ping_us = now_us + self._ping_period_us
        self._ping_seq = (self._ping_seq + 1) & 0xFFFFFFFF
        self._send(mavlink2.MAVLink_ping_message(now_us, self._ping_seq, 0, 0))

    def restart(self, now_us: int) -> None:
        """Simulation time went back: forget the peers, ping from ``now_us``."""
        if self._ping_period_us > 0:
            self.next_ping_us = now_us
        self.presence = PeerPresence()

    def on_heartbeat(self, msg: mavlink2.MAVLink_message) -> None:
        """HEARTBEAT: PX4 counts only ground stations (type GCS) for the data-link-loss failsafe."""
        if msg.type == mavlink2.MAV_TYPE_GCS:
            self._vehicle.gcs_heartbeat()
            self.presence.heartbeat(self._clock.now_s, self._wall_clock_s())

    def on_ping(self, msg: mavlink2.MAVLink_message) -> None:
        """PING: answer a request; note the echo of one of ours.

        As PX4: target 0/0 is a request to answer; a PING addressed to us is a reply to a ping
        of ours (answering it could start a ping-pong between vehicles): its time_usec is the
        simulation time we sent, which the peer has now read.
        """
        if msg.target_system == self._sysid and msg.target_component == self._compid:
            if self._ping_period_us > 0:
                self.presence.echoed(msg.time_usec / 1e6, self._clock.now_s, self._wall_clock_s())
            return
        if msg.target_system == 0 and msg.target_component == 0:
            self._send(
                mavlink2.MAVLink_ping_message(
                    time_usec=msg.time_usec,
                    seq=msg.seq,
                    target_system=msg.get_srcSystem(),
                    target_component=msg.get_srcComponent(),
                )
            )

    def on_timesync(self, msg: mavlink2.MAVLink_message) -> None:
        """TIMESYNC: answer a request with our boot time.

        As PX4 (mavlink_timesync): a request (tc1 == 0) is answered with our boot time in ns and
        ts1 echoed; an answer to our own requests (tc1 > 0) needs no offset estimate here.
        """
        if msg.tc1 == 0:
            self._send(messages.timesync_reply(msg, self._clock.now_us * 1000))
