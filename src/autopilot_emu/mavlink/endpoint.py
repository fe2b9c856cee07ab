"""One MAVLink link of a vehicle: a UDP socket that speaks MAVLink 2 as a PX4 instance does.

PX4 runs one MAVLink instance per link, each with its own port, peers and stream profile (PX4
SITL: the onboard profile from 14580+i to the offboard API on 14540+i, the normal profile from
18570+i to a ground station on 14550). An endpoint is one such instance: it receives and parses
datagrams, answers commands and the parameter and mission protocols, and streams telemetry read
from the vehicle (:mod:`autopilot_emu.mavlink.vehicle_port`) at its profile's rates
(:mod:`autopilot_emu.mavlink.streams`). The endpoints of one vehicle share a
:class:`~autopilot_emu.mavlink.link_hub.LinkHub`: one snapshot per poll, and every status text and
mission item reached forwarded on every link.

It never blocks and never reads the wall clock for scheduling: the simulation loop calls
:meth:`MavlinkEndpoint.poll` with the simulation time, and everything due by then is sent; a
message is built only when its stream is due. A poll with no traffic and nothing due costs one
failing ``recvfrom`` and one comparison.

The endpoint owns the link's lifecycle and its poll; its parts do the work, one concern each:
:mod:`~autopilot_emu.mavlink.inbound` (parsing, signing admission, peer learning, forwarding to
the vehicle's other links, dispatch through the :mod:`~autopilot_emu.mavlink.handlers` table),
:mod:`~autopilot_emu.mavlink.transmit` (framing, sending, relaying) and
:mod:`~autopilot_emu.mavlink.emission` (streams and announcements). The link is a UDP socket, or
a serial port (a pseudo-terminal, :mod:`autopilot_emu.mavlink.transport`). With a
:class:`~autopilot_emu.mavlink.shaping.LinkShaper` in the config, both directions are held until
the modelled link (a UART, a radio) delivers them; with a signing key the link signs every frame
it sends and handles only correctly signed frames (:mod:`autopilot_emu.mavlink.signing`).
"""

from __future__ import annotations

import errno
import logging
import math
import socket
import time
from collections.abc import Callable
from types import TracebackType

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import messages
from autopilot_emu.mavlink.command_handler import CommandHandler
from autopilot_emu.mavlink.emission import Emitter
from autopilot_emu.mavlink.endpoint_config import EndpointConfig, EndpointStats, PortInUseError
from autopilot_emu.mavlink.ftp import FtpServer
from autopilot_emu.mavlink.handlers import ProtocolHandlers, handler_table
from autopilot_emu.mavlink.inbound import Handler, Receiver
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.mission_protocol import MissionProtocol
from autopilot_emu.mavlink.param_protocol import ParamProtocol
from autopilot_emu.mavlink.presence import PeerPresence, PresenceHandler
from autopilot_emu.mavlink.setpoints import SetpointReceiver
from autopilot_emu.mavlink.shaping import LinkShaper
from autopilot_emu.mavlink.signing import LinkSigner
from autopilot_emu.mavlink.streams import StreamScheduler, profile_streams
from autopilot_emu.mavlink.tlog import TlogWriter
from autopilot_emu.mavlink.transmit import Transmitter, resolve
from autopilot_emu.mavlink.transport import Transport
from autopilot_emu.mavlink.vehicle_port import VehiclePort
from autopilot_emu.mavlink.vision import VisionReceiver
from autopilot_emu.params import ParamError

__all__ = [
    "HELD_HEARTBEAT_WALL_S",
    "EndpointConfig",
    "EndpointStats",
    "MavlinkEndpoint",
    "PortInUseError",
]

logger = logging.getLogger(__name__)

RATE_MULT_UPDATE_US = 1_000_000
"""How often a link with a data-rate limit re-fits its streams' rates, simulation us."""
HELD_HEARTBEAT_WALL_S = 1.0
"""While the simulation's clock is held, a link still sends HEARTBEAT this often, wall s
(:meth:`MavlinkEndpoint.keep_alive`)."""
STATUSTEXT_POLL_INTERVAL_US = 20_000
"""How often the vehicle's status-text queue is read, simulation microseconds."""
TLOG_FLUSH_INTERVAL_US = 1_000_000
"""How often the .tlog buffer is flushed, simulation microseconds."""
_NEVER = math.inf
_HEARTBEAT = mavlink2.MAVLINK_MSG_ID_HEARTBEAT


class MavlinkEndpoint:
    """PX4-flavoured MAVLink 2 endpoint for one vehicle.

    Args:
        vehicle: the flight stack behind the endpoint.
        config: addresses, ids, profile, tlog and stream rates.
        wall_clock_s: monotonic clock of the peers' retransmission timers (command duplicates,
            mission-transfer retries and timeouts); injectable for tests.
        hub: what this link shares with the vehicle's other links (None: a link of its own).
        transport: what the link speaks over (a serial port:
            :class:`~autopilot_emu.mavlink.transport.PtyTransport`, whose one peer replaces
            ``config.peers``); None: a UDP socket on ``config.bind_addr:listen_port``.

    Raises:
        PortInUseError: ``config.listen_port`` is already bound.
        ValueError: a stream rate names an unknown message; ``hub`` serves another vehicle.
    """

    def __init__(
        self,
        vehicle: VehiclePort,
        config: EndpointConfig,
        wall_clock_s: Callable[[], float] = time.monotonic,
        hub: LinkHub | None = None,
        transport: Transport | None = None,
    ) -> None:
        if hub is not None and hub.vehicle is not vehicle:
            raise ValueError("the link hub serves another vehicle")
        self._vehicle = vehicle
        self._config = config
        self._wall_clock_s = wall_clock_s
        self.stats = EndpointStats()
        self._clock = clock = LinkClock()
        self._hub = hub if hub is not None else LinkHub(vehicle)
        self._cursor = self._hub.subscribe()
        self._streams = StreamScheduler(
            profile_streams(config.profile, config.gps_rate_hz, config.distance_sensor_rate_hz),
            config.stream_rates_hz,
        )
        signer = (
            LinkSigner(self._hub.signing(config.signing_key))
            if config.signing_key is not None
            else None
        )
        stream = transport is not None and transport.is_stream  # a frame may span reads
        configured_peers = (
            [transport.getsockname()]
            if transport is not None and stream
            else list(dict.fromkeys(resolve(host, port) for host, port in config.peers))
        )
        self._tx = tx = Transmitter(
            config, configured_peers, self._streams, self.stats, clock, signer
        )
        send = tx.send
        self._params = ParamProtocol(vehicle.params, send)
        self._emitter = emitter = Emitter(
            self._hub,
            self._cursor,
            self._streams,
            tx,
            messages.MessageContext(
                sysid=config.sysid,
                params=vehicle.params,
                epoch_start_us=round(config.epoch_start_s * 1e6),
                ftp=config.ftp_root is not None,
            ),
            self._params.value_message,
            config.datarate_bytes_s,
            self.stats,
            clock,
            wall_clock_s,
        )
        self._missions = MissionProtocol(vehicle, send, emitter.announce, wall_clock_s)
        self._ftp = (
            FtpServer(config.ftp_root, send, wall_clock_s) if config.ftp_root is not None else None
        )
        self._presence = PresenceHandler(
            vehicle, config.sysid, config.compid, config.ping_period_s, send, clock, wall_clock_s
        )
        self._tlog = tx.tlog = (
            TlogWriter(config.tlog_path, config.epoch_start_s) if config.tlog_path else None
        )
        handlers: dict[int, Handler] = {}
        self._rx = Receiver(
            config, stream, handlers, self._hub, tx, self.stats, clock, self._tlog, signer
        )
        self._commands = CommandHandler(
            vehicle,
            config,
            wall_clock_s,
            self._rx,
            tx,
            emitter,
            self._streams,
            self._reschedule,
            self.stats,
            clock,
        )
        protocols = ProtocolHandlers(
            config.sysid,
            config.compid,
            vehicle,
            self._hub,
            self._cursor,
            self._params,
            self._missions,
            self._ftp,
            emitter,
            self._wake,
            self._reschedule,
        )
        handlers.update(
            handler_table(
                protocols,
                self._missions,
                self._commands,
                self._presence,
                SetpointReceiver(vehicle, config.sysid, config.compid, self.stats).handle,
                VisionReceiver(vehicle, clock, self.stats).handle,
            )
        )
        self._check_sysid_param()
        self._sock: socket.socket | Transport | None = (
            transport if transport is not None else self._bind(config.bind_addr, config.listen_port)
        )
        tx.sock = self._sock
        self._last_poll_s = -_NEVER
        self._next_work_s = -_NEVER
        self.quiet_from_s = _NEVER
        """With :attr:`quiet_until_s`: ``poll(now_s, receive=False)`` at a time in
        [quiet_from_s, quiet_until_s) would do nothing (nothing due, no modelled link, no tlog,
        no FTP transfer under way), so a caller that knows no datagram arrived may skip it."""
        self.quiet_until_s = -_NEVER
        """See :attr:`quiet_from_s` (an empty interval whenever every poll has work)."""
        self._next_statustext_us = 0
        self._next_flush_us = TLOG_FLUSH_INTERVAL_US
        self._next_rate_update_us = 0
        if config.forwarding:
            self._rx.join_forwarding()

    # --- lifecycle ---------------------------------------------------------------------------

    @staticmethod
    def _bind(host: str, port: int) -> socket.socket:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((host, port))
        except OSError as exc:
            sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise PortInUseError(host, port) from exc
            raise
        sock.setblocking(False)
        return sock

    def _check_sysid_param(self) -> None:
        try:
            param_sysid = self._vehicle.params.get("MAV_SYS_ID")
        except ParamError:
            return
        if param_sysid != self._config.sysid:
            logger.warning(
                "MAV_SYS_ID is %s but the endpoint speaks as system %d",
                param_sysid,
                self._config.sysid,
            )

    @property
    def local_address(self) -> tuple[str, int]:
        """(address, port) the socket is bound to."""
        if self._sock is None:
            raise RuntimeError("endpoint is closed")
        host, port = self._sock.getsockname()[:2]
        return (host, port)

    @property
    def shaper(self) -> LinkShaper | None:
        """The modelled link this endpoint's traffic crosses (None: none)."""
        return self._config.shaper

    @property
    def peers(self) -> tuple[tuple[str, int], ...]:
        """Addresses frames are sent to: configured peers, then learned ones."""
        return tuple(self._tx.peers)

    @property
    def presence(self) -> PeerPresence:
        """The peers' latest PING echoes and ground-station HEARTBEATs."""
        return self._presence.presence

    @property
    def rate_mult(self) -> float:
        """The streams' rate multiplier (1 unless a data-rate limit scales them down)."""
        return self._streams.rate_mult

    def close(self) -> None:
        """Flush and close the tlog, close the socket and the FTP session. Safe to call twice."""
        self._rx.leave_forwarding()
        if self._ftp is not None:
            self._ftp.close()
        if self._tlog is not None:
            self._tlog.close()
        if self._sock is not None:
            self._sock.close()
            self._sock = self._tx.sock = None
        self.quiet_until_s = -_NEVER

    def __enter__(self) -> MavlinkEndpoint:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    # --- the loop ----------------------------------------------------------------------------

    def fileno(self) -> int:
        """File descriptor of the socket, for a readiness poll of many links at once."""
        if self._sock is None:
            raise RuntimeError("endpoint is closed")
        return self._sock.fileno()

    def poll(self, now_s: float, receive: bool = True) -> None:
        """Handle received datagrams, then send whatever is due at simulation time ``now_s``.

        ``receive=False`` skips reading the socket: for a caller that polled the readiness of
        all its links at once (one syscall instead of one failing ``recvfrom`` per link).
        """
        sock = self._sock
        if sock is None:
            raise RuntimeError("endpoint is closed")
        clock = self._clock
        clock.now_s = now_s
        clock.now_us = round(now_s * 1e6)
        if receive:
            self._rx.drain(sock)
        shaper = self._config.shaper
        if shaper is not None and shaper.next_due_s <= now_s:
            for data, address in shaper.due_inbound(now_s):
                self._rx.datagram(data, address)
        ftp = self._ftp
        if ftp is not None and ftp.busy:
            ftp.tick()
        if now_s >= self._next_work_s or now_s < self._last_poll_s:
            self._work(now_s)
        self._last_poll_s = now_s
        if shaper is not None and shaper.next_due_s <= now_s:
            for frame in shaper.due_outbound(now_s):
                self._tx.sendto_peers(frame)
        self._update_quiet()

    def keep_alive(self) -> None:
        """Send HEARTBEAT if this link sent none for HELD_HEARTBEAT_WALL_S wall seconds.

        For a simulation whose clock is held (a lockstep waiting for a participant): its
        streams wait for simulated time, but a peer's heartbeat watchdog keeps wall time.
        MAVSDK's declares the vehicle lost after 3 wall s and then stops its own HEARTBEATs,
        so a held simulation waiting for those would wait until the peer counts as gone and
        then run on into the data-link-loss failsafe. A link whose HEARTBEAT stream is off
        stays silent. PX4 SITL in lockstep goes silent while its simulator pauses: this is a
        deviation (docs/scenarios.md).
        """
        # HEARTBEAT is a stream of every link (EVERY_LINK)
        if self._sock is None or self._streams.interval_us(_HEARTBEAT) <= 0:
            return
        if self._wall_clock_s() - self._emitter.heartbeat_wall_s >= HELD_HEARTBEAT_WALL_S:
            self._emitter.emit(_HEARTBEAT)

    def _update_quiet(self) -> None:
        """Recompute :attr:`quiet_from_s` / :attr:`quiet_until_s` after the state changed."""
        self.quiet_from_s = self._last_poll_s
        if (
            self._config.shaper is not None
            or self._tlog is not None
            or self._sock is None
            or (self._ftp is not None and self._ftp.busy)
        ):
            self.quiet_until_s = -_NEVER
        else:
            self.quiet_until_s = self._next_work_s

    def _work(self, now_s: float) -> None:
        """Periodic part of poll: streams, status texts, parameter list, tlog flush."""
        now_us = self._clock.now_us
        if now_s < self._last_poll_s:
            logger.info("simulation time went back to %.6f s: restarting streams", now_s)
            self._streams.restart(now_us)
            self._next_statustext_us = now_us
            self._presence.restart(now_us)
            self._next_flush_us = now_us
        if self._config.datarate_bytes_s > 0 and now_us >= self._next_rate_update_us:
            self._next_rate_update_us = now_us + RATE_MULT_UPDATE_US
            self._emitter.update_rate_mult(now_us)
        due = self._streams.pop_due(now_us)
        if due:
            self._emitter.emit_streams(due)
        if now_us >= self._presence.next_ping_us:
            self._presence.send_ping(now_us)
        if now_us >= self._next_statustext_us:
            self._next_statustext_us = now_us + STATUSTEXT_POLL_INTERVAL_US
            self._emitter.forward_announcements()
        if self._params.list_pending:
            self._params.send_list_batch()
        if self._missions.busy:
            self._missions.tick()
        if self._tlog is not None and now_us >= self._next_flush_us:
            self._next_flush_us = now_us + TLOG_FLUSH_INTERVAL_US
            self._tlog.flush()
        self._reschedule()

    def _reschedule(self) -> None:
        """Compute the earliest simulation time at which :meth:`_work` has something to do."""
        if self._params.list_pending or self._missions.busy:
            self._wake()
            return
        next_us = min(
            self._streams.next_due_us, self._next_statustext_us, self._presence.next_ping_us
        )
        if self._tlog is not None:
            next_us = min(next_us, self._next_flush_us)
        # Half a microsecond early so that float rounding never delays a due message a poll.
        self._next_work_s = (next_us - 0.5) / 1e6
        self._update_quiet()

    def _wake(self) -> None:
        """Make the next poll do :meth:`_work` (and every poll, until it reschedules)."""
        self._next_work_s = -_NEVER
        self.quiet_until_s = -_NEVER

    def announce(self, severity: int, text: str) -> None:
        """Send ``text`` as STATUSTEXT (chunked when longer than 50 bytes)."""
        self._emitter.announce(severity, text)
