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

Every frame goes to the configured peers and to every address MAVLink has been received from, as
PX4 does, except a COMMAND_ACK, which goes to the address the command came from alone. Frames for
or from other components and systems (a camera, a ground station) are relayed between the
vehicle's links (:mod:`autopilot_emu.mavlink.forwarding`); a parameter one link sets is announced
on all. The link is a UDP socket, or a serial port (a pseudo-terminal,
:mod:`autopilot_emu.mavlink.transport`). Malformed input is counted in
:attr:`MavlinkEndpoint.stats` and logged, never raised; errors while sending are counted and
otherwise ignored. With a :class:`~autopilot_emu.mavlink.shaping.LinkShaper` in the config, both
directions are held until the modelled link (a UART, a radio) delivers them. With a signing key
in the config the link signs every frame it sends and handles only correctly signed frames
(:mod:`autopilot_emu.mavlink.signing`); frames relayed from the vehicle's other links pass
verbatim, signature included, as PX4 relays them.
"""

from __future__ import annotations

import errno
import logging
import math
import socket
import time
from collections import OrderedDict
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing, messages
from autopilot_emu.mavlink.commands import (
    ACCEPTED,
    DENIED,
    CommandDispatcher,
    CommandRequest,
)
from autopilot_emu.mavlink.distance_sensor import DistanceSensorForwarder, latest_messages
from autopilot_emu.mavlink.forwarding import required_target, should_forward
from autopilot_emu.mavlink.ftp import FtpServer
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.mission_protocol import MissionProtocol
from autopilot_emu.mavlink.param_protocol import ParamProtocol
from autopilot_emu.mavlink.presence import PeerPresence
from autopilot_emu.mavlink.setpoints import (
    SetpointError,
    decode_attitude,
    decode_global,
    decode_local,
)
from autopilot_emu.mavlink.shaping import LinkShaper
from autopilot_emu.mavlink.signing import KEY_BYTES, LinkSigner, Verdict
from autopilot_emu.mavlink.streams import (
    STREAMABLE,
    StreamProfile,
    StreamScheduler,
    StreamSpec,
    profile_streams,
)
from autopilot_emu.mavlink.tlog import TlogWriter
from autopilot_emu.mavlink.transport import Transport
from autopilot_emu.mavlink.vehicle_port import TelemetrySnapshot, VehiclePort
from autopilot_emu.mavlink.vision import (
    VisionError,
    decode_odometry,
    decode_vision_position_estimate,
)
from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.modes.offboard import LocalFrame
from autopilot_emu.params import ParamError

logger = logging.getLogger(__name__)

MAX_DATAGRAMS_PER_POLL = 64
"""Datagrams drained per poll; the rest wait for the next poll."""
MAX_DATAGRAM_BYTES = 65535
MAX_LEARNED_PEERS = 16
"""Remote addresses remembered from received traffic, beyond the configured peers; when more
talk to the vehicle, the one heard from least recently is forgotten (it is re-learned as soon as
it sends again, so every sender always gets its replies)."""
MAX_HELD_HEARTBEATS = 8
"""Other components' HEARTBEATs a link holds for its next own frame; older ones are dropped."""
RATE_MULT_UPDATE_US = 1_000_000
"""How often a link with a data-rate limit re-fits its streams' rates, simulation us."""

MAVLINK2_NON_PAYLOAD_BYTES = 12
"""Header (10) and checksum (2) of an unsigned MAVLink 2 frame."""

_MAX_FRAME_BYTES: dict[int, float] = {
    msg_id: float(mavlink2.mavlink_map[msg_id].unpacker.size + MAVLINK2_NON_PAYLOAD_BYTES)
    for msg_id in (getattr(mavlink2, f"MAVLINK_MSG_ID_{name}") for name in STREAMABLE)
}
"""Bytes of each stream's frame with its full payload (PX4's size before it has averages)."""


_FAST_STREAMS: dict[int, tuple[messages.FieldsBuilder, framing.FieldsFormat]] = {
    msg_id: (fields, framing.fields_format(msg_id)) for msg_id, fields in messages.FIELDS.items()
}
"""The hot streams: packed from their field values, without pymavlink objects."""

HELD_HEARTBEAT_WALL_S = 1.0
"""While the simulation's clock is held, a link still sends HEARTBEAT this often, wall s
(:meth:`MavlinkEndpoint.keep_alive`)."""
STATUSTEXT_POLL_INTERVAL_US = 20_000
"""How often the vehicle's status-text queue is read, simulation microseconds."""
TLOG_FLUSH_INTERVAL_US = 1_000_000
"""How often the .tlog buffer is flushed, simulation microseconds."""
_NEVER = math.inf
_ANY_COMPONENT_COMMANDS = frozenset(
    {mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink2.MAV_CMD_REQUEST_PROTOCOL_VERSION}
)
"""Commands PX4 answers whatever their target component (evaluate_target_ok)."""


class PortInUseError(OSError):
    """The UDP port the endpoint should listen on is taken (another vehicle or PX4 SITL)."""

    def __init__(self, host: str, port: int) -> None:
        super().__init__(
            errno.EADDRINUSE,
            f"UDP {host}:{port} is already in use (another vehicle or a PX4 SITL running?)",
        )
        self.host = host
        self.port = port


@dataclass(frozen=True)
class EndpointConfig:
    """Addresses, identity and rates of one vehicle's MAVLink endpoint."""

    sysid: int = 1
    """Our MAVLink system id (MAVSDK expects 1 for the first vehicle)."""
    compid: int = 1
    """Our component id: MAV_COMP_ID_AUTOPILOT1."""
    bind_addr: str = "127.0.0.1"
    """IPv4 address to listen on."""
    listen_port: int = 14580
    """UDP port to listen on (PX4 SITL: 14580 + instance, or 18570 + instance for the
    ground-station link); 0 lets the OS pick one."""
    peers: tuple[tuple[str, int], ...] = (("127.0.0.1", 14540),)
    """Addresses every frame is sent to, besides addresses learned from received traffic."""
    profile: StreamProfile = StreamProfile.ONBOARD
    """PX4 MAVLink mode of the link: its default streams and rates."""
    tlog_path: Path | None = None
    """Where to append a .tlog of every frame sent and every valid frame received (CRC checked,
    known message id); None: no log."""
    epoch_start_s: float = field(default_factory=time.time)
    """Unix time at simulation t = 0, s (tlog timestamps, SYSTEM_TIME)."""
    stream_rates_hz: Mapping[str, float] = field(default_factory=dict)
    """Per-message overrides of the profile's rates, e.g. {"ATTITUDE": 50.0}; 0 = off. Any
    streamable message (streams.STREAMABLE) may be named, also one the profile leaves off."""
    gps_rate_hz: float = 10.0
    """Rate of the vehicle's GPS receiver, Hz: PX4's onboard profile sends GPS_RAW_INT on every
    new fix ("unlimited" rate), so the stream runs at this rate."""
    distance_sensor_rate_hz: float = 0.0
    """Rate of the vehicle's fastest range finder, Hz: DISTANCE_SENSOR goes out at this rate
    with each new reading (0: no range finders, the stream is off until requested)."""
    ftp_root: Path | None = None
    """Directory served over MAVLink FTP (must exist); None: FILE_TRANSFER_PROTOCOL is not
    answered, as PX4 with FTP off (``mavlink start`` without ``-x``)."""
    forwarding: bool = True
    """Relay frames for and from the vehicle's other components to and from its other links
    with forwarding on (PX4's ``mavlink start -f``, on for every PX4 SITL link)."""
    datarate_bytes_s: float = 0.0
    """Data-rate limit of the link, B/s (PX4's ``mavlink start -r``, MAV_x_RATE): the streams'
    rates are scaled down together so their load fits, as PX4 does on a serial link; 0: no
    limit (PX4 SITL's UDP links run with a rate far above what the streams need)."""
    shaper: LinkShaper | None = None
    """The modelled link (UART, radio) this endpoint's traffic crosses: every frame sent and
    every datagram received is held until the shaper says it arrived (see
    :mod:`autopilot_emu.mavlink.shaping`); None: sent and handled at once."""
    signing_key: bytes | None = None
    """MAVLink 2 signing key (32 bytes): sign every frame sent, handle only correctly signed
    frames (:mod:`autopilot_emu.mavlink.signing`); None: no signing, every frame handled."""
    ping_period_s: float = 0.0
    """Send a PING request (target 0/0, ``time_usec`` = simulation time) this often, simulated
    s, and note the peers' echoes in :attr:`MavlinkEndpoint.presence`; 0: none. PX4 has a PING
    stream of its own; a lockstep run asks for a fast one to learn how far each companion has
    read (``harness.lockstep``)."""

    def __post_init__(self) -> None:
        if not 1 <= self.sysid <= 255 or not 1 <= self.compid <= 255:
            raise ValueError(f"sysid/compid must be 1..255, got {self.sysid}/{self.compid}")
        if not 0 <= self.listen_port <= 65535:
            raise ValueError(f"listen_port must be 0..65535, got {self.listen_port}")
        if not self.gps_rate_hz > 0:
            raise ValueError(f"gps_rate_hz must be positive, got {self.gps_rate_hz}")
        if not self.datarate_bytes_s >= 0:
            raise ValueError(f"datarate_bytes_s must be >= 0, got {self.datarate_bytes_s}")
        if not self.ping_period_s >= 0:
            raise ValueError(f"ping_period_s must be >= 0, got {self.ping_period_s}")
        if self.signing_key is not None and len(self.signing_key) != KEY_BYTES:
            raise ValueError(
                f"signing_key must have {KEY_BYTES} bytes, got {len(self.signing_key)}"
            )
        if not self.distance_sensor_rate_hz >= 0:
            raise ValueError(
                f"distance_sensor_rate_hz must be >= 0, got {self.distance_sensor_rate_hz}"
            )


@dataclass
class EndpointStats:
    """Counters of what the endpoint saw and did."""

    datagrams_received: int = 0
    frames_received: int = 0
    """Well-formed MAVLink frames received (including unknown message ids)."""
    frames_sent: int = 0
    """Frames sent (each to every peer)."""
    parse_errors: int = 0
    """Garbage bytes, bad CRCs, truncated frames."""
    unknown_messages: int = 0
    """Frames whose message id is not in the common dialect."""
    recv_errors: int = 0
    send_errors: int = 0
    """Failed sendto calls (peer not listening, buffer full)."""
    commands_handled: int = 0
    """COMMAND_LONG/INT executed and ACKed."""
    commands_duplicate: int = 0
    """Retransmissions re-ACKed from the cache without executing."""
    commands_ignored: int = 0
    """Commands addressed to another system or component and not forwarded (no ACK, as PX4)."""
    frames_forwarded: int = 0
    """Received frames relayed to the vehicle's other links (forwarding.should_forward)."""
    frames_relayed: int = 0
    """Frames received by another link of the vehicle and sent out of this one."""
    setpoints_received: int = 0
    """Offboard setpoints addressed to us and passed to the vehicle."""
    setpoints_ignored: int = 0
    """Offboard setpoints addressed to us that could not be flown (logged once per reason)."""
    vision_received: int = 0
    """VISION_POSITION_ESTIMATE / ODOMETRY samples passed to the vehicle."""
    vision_ignored: int = 0
    """External-vision messages that could not be used (logged once per reason)."""
    handler_errors: int = 0
    """Exceptions raised while handling a received message."""
    encode_errors: int = 0
    """Exceptions raised while building or packing an outgoing message."""
    frames_unsigned_rejected: int = 0
    """Signed link: unsigned frames (and MAVLink 1 frames) dropped unhandled."""
    frames_bad_signature: int = 0
    """Signed link: frames whose signature does not verify (another key), dropped."""
    frames_replay_rejected: int = 0
    """Signed link: correctly signed frames with an old timestamp (replays), dropped."""
    frames_unsigned_accepted: int = 0
    """Signed link: unsigned RADIO_STATUS / ADSB_VEHICLE / COLLISION, handled (as PX4)."""


def _resolve(host: str, port: int) -> tuple[str, int]:
    """(host, port) -> (IPv4 address, port) as recvfrom reports addresses."""
    info = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
    address = info[0][4]
    return (address[0], address[1])


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
        self.presence = PeerPresence()
        """The peers' latest PING echoes and ground-station HEARTBEATs."""
        self._ping_period_us = round(config.ping_period_s * 1e6)
        self._next_ping_us = 0 if self._ping_period_us > 0 else 2**62
        self._ping_seq = 0
        self._hub = hub if hub is not None else LinkHub(vehicle)
        self._cursor = self._hub.subscribe()
        self._streams = StreamScheduler(
            profile_streams(config.profile, config.gps_rate_hz, config.distance_sensor_rate_hz),
            config.stream_rates_hz,
        )
        self._distance_sensors = DistanceSensorForwarder()
        self._mav = mavlink2.MAVLink(None, srcSystem=config.sysid, srcComponent=config.compid)
        """The parser of received frames."""
        self._mav.robust_parsing = True
        self._seq = 0
        """Sequence number of the next frame sent."""
        self._signer = (
            LinkSigner(self._hub.signing(config.signing_key))
            if config.signing_key is not None
            else None
        )
        self._encode = framing.encode if self._signer is None else self._signer.encode
        self._encode_fields = (
            framing.encode_fields if self._signer is None else self._signer.encode_fields
        )
        self._context = messages.MessageContext(
            sysid=config.sysid,
            params=vehicle.params,
            epoch_start_us=round(config.epoch_start_s * 1e6),
            ftp=config.ftp_root is not None,
        )
        self._params = ParamProtocol(vehicle.params, self._send)
        self._commands = CommandDispatcher(vehicle, self, wall_clock_s)
        self._missions = MissionProtocol(vehicle, self._send, self.announce, wall_clock_s)
        self._mission_status: tuple[int, int, int] | None = None
        self._ftp = (
            FtpServer(config.ftp_root, self._send, wall_clock_s)
            if config.ftp_root is not None
            else None
        )
        self._handlers: dict[int, Callable[[mavlink2.MAVLink_message], None]] = {
            mavlink2.MAVLINK_MSG_ID_HEARTBEAT: self._on_heartbeat,
            mavlink2.MAVLINK_MSG_ID_MISSION_COUNT: self._on_mission(self._missions.handle_count),
            mavlink2.MAVLINK_MSG_ID_MISSION_ITEM_INT: self._on_mission(self._missions.handle_item),
            mavlink2.MAVLINK_MSG_ID_MISSION_ITEM: self._on_mission(self._missions.handle_item),
            mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: self._on_mission(
                self._missions.handle_request_list
            ),
            mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST_INT: self._on_mission(
                self._missions.handle_request
            ),
            mavlink2.MAVLINK_MSG_ID_MISSION_REQUEST: self._on_mission(
                self._missions.handle_request
            ),
            mavlink2.MAVLINK_MSG_ID_MISSION_CLEAR_ALL: self._on_mission(
                self._missions.handle_clear_all
            ),
            mavlink2.MAVLINK_MSG_ID_MISSION_SET_CURRENT: self._on_mission_set_current,
            mavlink2.MAVLINK_MSG_ID_COMMAND_LONG: self._on_command,
            mavlink2.MAVLINK_MSG_ID_COMMAND_INT: self._on_command,
            mavlink2.MAVLINK_MSG_ID_PARAM_REQUEST_LIST: self._on_param_request_list,
            mavlink2.MAVLINK_MSG_ID_PARAM_REQUEST_READ: self._on_param_request_read,
            mavlink2.MAVLINK_MSG_ID_PARAM_SET: self._on_param_set,
            mavlink2.MAVLINK_MSG_ID_PING: self._on_ping,
            mavlink2.MAVLINK_MSG_ID_TIMESYNC: self._on_timesync,
            mavlink2.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED: self._on_setpoint,
            mavlink2.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT: self._on_setpoint,
            mavlink2.MAVLINK_MSG_ID_SET_ATTITUDE_TARGET: self._on_setpoint,
            mavlink2.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: self._on_ftp,
            mavlink2.MAVLINK_MSG_ID_VISION_POSITION_ESTIMATE: self._on_vision,
            mavlink2.MAVLINK_MSG_ID_ODOMETRY: self._on_vision,
        }
        self._setpoint_problems: set[str] = set()
        self._vision_problems: set[str] = set()
        self._stream = transport is not None and transport.is_stream
        """The link is a byte stream (serial): a frame may span reads."""
        self._configured_peers = (
            [transport.getsockname()]
            if self._stream
            else list(dict.fromkeys(_resolve(host, port) for host, port in config.peers))
        )
        self._learned_peers: OrderedDict[tuple[str, int], None] = OrderedDict()
        self._peers = list(self._configured_peers)
        self._tlog = (
            TlogWriter(config.tlog_path, config.epoch_start_s) if config.tlog_path else None
        )
        self._now_s = 0.0
        self._now_us = 0
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
        self._replies: list[mavlink2.MAVLink_message] = []
        self._bytes_out = 0
        """Bytes of every frame this link sent."""
        self._emission_bytes: dict[int, float] = {}
        """Running average of the bytes one emission of each stream took."""
        self._next_rate_update_us = 0
        self._statustext_id = 0
        self._check_sysid_param()
        self._sock: socket.socket | Transport | None = (
            transport if transport is not None else self._bind(config.bind_addr, config.listen_port)
        )
        self._sender: tuple[str, int] | None = None
        """Address of the datagram being handled (COMMAND_ACKs go back to it alone)."""
        self._forwarded = False
        """The frame being handled was relayed to the vehicle's other links."""
        self._held_heartbeats: list[bytes] = []
        """Other components' HEARTBEATs waiting for this link's next own frame (``_relay``)."""
        self._heartbeat_wall_s = -_NEVER
        """Wall time of this link's last own HEARTBEAT (:meth:`keep_alive`)."""
        self._forward_member = self._hub.forwarding.join(self._relay) if config.forwarding else None

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
        return tuple(self._peers)

    def close(self) -> None:
        """Flush and close the tlog, close the socket and the FTP session. Safe to call twice."""
        if self._forward_member is not None:
            self._hub.forwarding.leave(self._forward_member)
            self._forward_member = None
        if self._ftp is not None:
            self._ftp.close()
        if self._tlog is not None:
            self._tlog.close()
        if self._sock is not None:
            self._sock.close()
            self._sock = None
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
        self._now_s = now_s
        self._now_us = round(now_s * 1e6)
        if receive:
            self._receive(sock, now_s)
        shaper = self._config.shaper
        if shaper is not None and shaper.next_due_s <= now_s:
            for data, address in shaper.due_inbound(now_s):
                self._on_datagram(data, address)
        ftp = self._ftp
        if ftp is not None and ftp.busy:
            ftp.tick()
        if now_s >= self._next_work_s or now_s < self._last_poll_s:
            self._work(now_s)
        self._last_poll_s = now_s
        if shaper is not None and shaper.next_due_s <= now_s:
            for frame in shaper.due_outbound(now_s):
                self._sendto_peers(frame)
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
        heartbeat = mavlink2.MAVLINK_MSG_ID_HEARTBEAT  # a stream of every link (EVERY_LINK)
        if self._sock is None or self._streams.interval_us(heartbeat) <= 0:
            return
        if self._wall_clock_s() - self._heartbeat_wall_s >= HELD_HEARTBEAT_WALL_S:
            self._emit(heartbeat)

    def _receive(self, sock: socket.socket, now_s: float) -> None:
        """Drain up to MAX_DATAGRAMS_PER_POLL datagrams: handle them, or hand them to the shaper."""
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            try:
                data, address = sock.recvfrom(MAX_DATAGRAM_BYTES)
            except BlockingIOError:
                break
            except OSError as exc:
                self.stats.recv_errors += 1
                logger.debug("recvfrom failed: %s", exc)
                break
            if self._config.shaper is None:
                self._on_datagram(data, address)
            else:
                self._config.shaper.inbound(now_s, data, address)

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
        now_us = self._now_us
        if now_s < self._last_poll_s:
            logger.info("simulation time went back to %.6f s: restarting streams", now_s)
            self._streams.restart(now_us)
            self._next_statustext_us = now_us
            if self._ping_period_us > 0:
                self._next_ping_us = now_us
            self.presence = PeerPresence()
            self._next_flush_us = now_us
        if self._config.datarate_bytes_s > 0 and now_us >= self._next_rate_update_us:
            self._next_rate_update_us = now_us + RATE_MULT_UPDATE_US
            self._update_rate_mult(now_us)
        due = self._streams.pop_due(now_us)
        if due:
            self._emit_streams(due)
        if now_us >= self._next_ping_us:
            self._next_ping_us = now_us + self._ping_period_us
            self._ping_seq = (self._ping_seq + 1) & 0xFFFFFFFF
            self._send(mavlink2.MAVLink_ping_message(now_us, self._ping_seq, 0, 0))
        if now_us >= self._next_statustext_us:
            self._next_statustext_us = now_us + STATUSTEXT_POLL_INTERVAL_US
            texts, reached = self._hub.announcements(self._cursor)
            for severity, text in texts:
                self.announce(severity, text)
            self._mission_events(reached)
            for command in self._hub.component_commands(self._cursor):
                self._send_component_command(command)
            for name in self._hub.changed_params(self._cursor):
                self._send(self._params.value_message(name))
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
            self._next_work_s = -_NEVER
            self.quiet_until_s = -_NEVER
            return
        next_us = min(self._streams.next_due_us, self._next_statustext_us, self._next_ping_us)
        if self._tlog is not None:
            next_us = min(next_us, self._next_flush_us)
        # Half a microsecond early so that float rounding never delays a due message a poll.
        self._next_work_s = (next_us - 0.5) / 1e6
        self._update_quiet()

    def _telemetry(self) -> TelemetrySnapshot:
        """The vehicle's snapshot for this poll (read once per poll for all its links)."""
        return self._hub.telemetry(self._now_us)

    # --- sending -----------------------------------------------------------------------------

    def _send(self, message: mavlink2.MAVLink_message, to: tuple[str, int] | None = None) -> None:
        """Frame ``message`` with our ids and the next sequence number; send it to every peer.

        ``to``: to that address alone (see :meth:`_transmit`).
        """
        config = self._config
        try:
            frame = self._encode(message, self._seq, config.sysid, config.compid)
        except Exception:
            self.stats.encode_errors += 1
            logger.exception("cannot pack %s", message.get_type())
            return
        self._seq = (self._seq + 1) & 0xFF
        self.stats.frames_sent += 1
        self._bytes_out += len(frame)
        self._transmit(frame, to)
        if self._held_heartbeats and to is None:  # after a frame every peer got
            self._release_heartbeats()

    def _send_fields(
        self,
        msg_id: int,
        snapshot: TelemetrySnapshot,
        fields: messages.FieldsBuilder,
        fmt: framing.FieldsFormat,
    ) -> None:
        """Build hot stream ``msg_id`` from this poll's snapshot as field values; frame, send.

        The same frame as ``_send(_build(msg_id))``, without the pymavlink object.
        """
        config = self._config
        try:
            values = fields(snapshot, self._context)
            if values is None:
                return
            frame = self._encode_fields(fmt, values, self._seq, config.sysid, config.compid)
        except Exception:
            self.stats.encode_errors += 1
            logger.exception("cannot build message %d", msg_id)
            return
        self._seq = (self._seq + 1) & 0xFF
        self.stats.frames_sent += 1
        self._bytes_out += len(frame)
        sock = self._sock
        if config.shaper is not None or self._tlog is not None or sock is None:
            self._transmit(frame)
        else:
            for peer in self._peers:  # _transmit's work on an unshaped link without a tlog
                try:
                    sock.sendto(frame, peer)
                except OSError:
                    self.stats.send_errors += 1
        if self._held_heartbeats:
            self._release_heartbeats()

    def _relay(self, frame: bytes) -> None:
        """Send a frame another link of the vehicle received, unchanged (forwarding).

        A HEARTBEAT of another component of our system (the camera's) waits for this link's
        next own frame and goes right after it: the first frame a client that starts listening
        receives from this system is then the autopilot's. mavsdk_server 4.0 decides whether a
        system has an autopilot once, on the system's first HEARTBEAT; had it come from the
        camera, it would wait for an autopilot forever (seen while a lockstep run held the
        simulation, the autopilot silent, as the camera's heartbeat was relayed). The wait is
        at most one period of our own HEARTBEAT; a link whose HEARTBEAT stream is off relays
        at once.
        """
        ids = framing.source_and_msgid(frame)
        if (
            ids is not None
            and ids[0] == self._config.sysid
            and ids[1] != self._config.compid
            and ids[2] == mavlink2.MAVLINK_MSG_ID_HEARTBEAT
            and self._streams.interval_us(mavlink2.MAVLINK_MSG_ID_HEARTBEAT) > 0
        ):
            if len(self._held_heartbeats) >= MAX_HELD_HEARTBEATS:
                del self._held_heartbeats[0]
            self._held_heartbeats.append(frame)
            return
        self.stats.frames_relayed += 1
        self._transmit(frame)

    def _release_heartbeats(self) -> None:
        """Relay the held HEARTBEATs (see :meth:`_relay`), right after one of our own frames."""
        held, self._held_heartbeats = self._held_heartbeats, []
        for frame in held:
            self.stats.frames_relayed += 1
            self._transmit(frame)

    def _transmit(self, frame: bytes, to: tuple[str, int] | None = None) -> None:
        """Send an encoded frame to every peer (through the shaper, if any) and log it.

        ``to``: to that peer alone (a COMMAND_ACK to the client that sent the command), unless
        the link is modelled: a UART or radio carries every byte to its far end, whoever asked.
        """
        if self._config.shaper is None:
            self._sendto_peers(frame, to)
        else:
            self._config.shaper.outbound(self._now_s, frame)
        if self._tlog is not None:
            self._tlog.write(self._now_s, frame)

    def _sendto_peers(self, frame: bytes, to: tuple[str, int] | None = None) -> None:
        sock = self._sock
        if sock is not None:
            for peer in self._peers if to is None else (to,):
                try:
                    sock.sendto(frame, peer)
                except OSError:
                    self.stats.send_errors += 1

    def _send_component_command(self, command: ComponentCommand) -> None:
        """Send a COMMAND_LONG from the autopilot to another component of its system.

        PX4 sends a vehicle command addressed elsewhere on every link; the camera ACKs it.
        """
        self._send(
            mavlink2.MAVLink_command_long_message(
                target_system=self._config.sysid,
                target_component=command.target_component,
                command=command.command,
                confirmation=0,
                param1=command.params[0],
                param2=command.params[1],
                param3=command.params[2],
                param4=command.params[3],
                param5=command.params[4],
                param6=command.params[5],
                param7=command.params[6],
            )
        )

    def _build(self, msg_id: int) -> mavlink2.MAVLink_message | None:
        """Build message ``msg_id`` from this poll's snapshot (None: nothing to report).

        An exception from ``vehicle.telemetry()`` propagates (a flight-stack bug); one from
        building the message is counted in ``stats.encode_errors`` and logged.
        """
        if msg_id == mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT:
            return messages.mission_current(*self._vehicle.mission_status())
        snapshot = self._telemetry()
        try:
            return messages.BUILDERS[msg_id](snapshot, self._context)
        except Exception:
            self.stats.encode_errors += 1
            logger.exception("cannot build message %d", msg_id)
            return None

    def _emit_streams(self, due: list[StreamSpec]) -> None:
        """Send the due streams in order; the hot ones packed from one snapshot read for all."""
        if self._config.datarate_bytes_s > 0:  # every emission's bytes are averaged
            for spec in due:
                self._emit(spec.msg_id)
            return
        snapshot = None
        for spec in due:
            msg_id = spec.msg_id
            fast = _FAST_STREAMS.get(msg_id)
            if fast is None or msg_id == mavlink2.MAVLINK_MSG_ID_HEARTBEAT:
                self._emit(msg_id)
                continue
            if snapshot is None:
                snapshot = self._telemetry()
            self._send_fields(msg_id, snapshot, *fast)

    def _emit(self, msg_id: int) -> None:
        before = self._bytes_out
        if msg_id == mavlink2.MAVLINK_MSG_ID_HEARTBEAT:
            self._heartbeat_wall_s = self._wall_clock_s()
        fast = _FAST_STREAMS.get(msg_id)
        if fast is not None:
            self._send_fields(msg_id, self._telemetry(), *fast)
        elif msg_id == mavlink2.MAVLINK_MSG_ID_DISTANCE_SENSOR:
            for reading in self._distance_sensors.new_messages(self._telemetry().distance_sensors):
                self._send(reading)
        else:
            message = self._build(msg_id)
            if message is not None:
                self._send(message)
        sent = self._bytes_out - before
        if sent > 0 and self._config.datarate_bytes_s > 0:
            average = self._emission_bytes.get(msg_id)
            self._emission_bytes[msg_id] = sent if average is None else 0.9 * average + 0.1 * sent

    def _update_rate_mult(self, now_us: int) -> None:
        """Fit the streams into ``datarate_bytes_s`` (PX4's ``Mavlink::update_rate_mult``).

        A stream's load is its bytes per emission (a running average of what was sent; before
        its first emission the largest frame of its message) times its configured rate.
        """
        sizes = _MAX_FRAME_BYTES | self._emission_bytes
        const, scaled = self._streams.bytes_per_s(sizes)
        if scaled > 0:
            mult = (self._config.datarate_bytes_s - const) / scaled
            self._streams.set_rate_mult(mult, now_us)

    @property
    def rate_mult(self) -> float:
        """The streams' rate multiplier (1 unless a data-rate limit scales them down)."""
        return self._streams.rate_mult

    def announce(self, severity: int, text: str) -> None:
        """Send ``text`` as STATUSTEXT (chunked when longer than 50 bytes)."""
        self._statustext_id = self._statustext_id % 0xFFFF + 1
        for chunk in messages.statustext_chunks(severity, text, self._statustext_id):
            self._send(chunk)

    # --- receiving ---------------------------------------------------------------------------

    def _on_datagram(self, data: bytes, address: tuple[str, int]) -> None:
        """Parse one datagram and handle each frame in it."""
        self.stats.datagrams_received += 1
        parser = self._mav
        try:
            frames = parser.parse_buffer(data) or []
        except Exception as exc:
            self.stats.parse_errors += 1
            logger.debug("unparsable datagram from %s: %s", address, exc)
            frames = []
        if parser.buf_len() > 0 and not self._stream:
            # A frame cut short by the end of the datagram: drop it rather than let it swallow
            # the start of the next datagram.
            self.stats.parse_errors += 1
            logger.debug("truncated frame from %s (%d bytes)", address, parser.buf_len())
            parser.buf = bytearray()
            parser.buf_index = 0
            parser.expected_length = mavlink2.HEADER_LEN_V1 + 2
        learned = False
        signer = self._signer
        self._sender = address
        for msg in frames:
            msg_id = msg.get_msgId()
            if msg_id == mavlink2.MAVLINK_MSG_ID_BAD_DATA:
                self.stats.parse_errors += 1
                logger.debug("bad data from %s: %s", address, getattr(msg, "reason", ""))
                continue
            if signer is not None and not self._admit(signer, msg, address):
                continue
            self.stats.frames_received += 1
            if msg_id == mavlink2.MAVLINK_MSG_ID_UNKNOWN:
                # Not logged: without the dialect's CRC extra its checksum cannot be verified.
                self.stats.unknown_messages += 1
                continue
            if self._tlog is not None:
                self._tlog.write(self._now_s, bytes(msg.get_msgbuf()))
            if not learned:
                self._learn_peer(address)
                learned = True
            self._forwarded = False
            member = self._forward_member
            if member is not None:
                self._hub.forwarding.heard(member, msg.get_srcSystem(), msg.get_srcComponent())
            if member is not None and should_forward(msg, self._config.sysid, self._config.compid):
                frame = bytes(msg.get_msgbuf())
                target = required_target(msg, self._config.sysid)
                if self._hub.forwarding.forward(member, frame, target):
                    self.stats.frames_forwarded += 1
                    self._forwarded = True
            handler = self._handlers.get(msg_id)
            if handler is None or self._from_ourselves(msg):
                continue
            try:
                handler(msg)
            except Exception:
                self.stats.handler_errors += 1
                logger.exception("error handling %s from %s", msg.get_type(), address)
            self._hub.touched()

    def _admit(
        self, signer: LinkSigner, msg: mavlink2.MAVLink_message, address: tuple[str, int]
    ) -> bool:
        """Signed link: whether to handle ``msg``; rejections counted and logged (rate-limited).

        A rejected frame is not handled, logged to the tlog, forwarded, nor does its sender
        become a peer.
        """
        verdict = signer.check(msg.get_msgbuf())
        if verdict is Verdict.SIGNED:
            return True
        stats = self.stats
        if verdict is Verdict.UNSIGNED_ALLOWED:
            stats.frames_unsigned_accepted += 1
            return True
        if verdict is Verdict.UNSIGNED:
            stats.frames_unsigned_rejected += 1
        elif verdict is Verdict.BAD_SIGNATURE:
            stats.frames_bad_signature += 1
        else:
            stats.frames_replay_rejected += 1
        signer.log_rejection(verdict, msg.get_type(), address)
        return False

    def _learn_peer(self, address: tuple[str, int]) -> None:
        peer = (address[0], address[1])
        if peer in self._configured_peers:
            return
        learned = self._learned_peers
        if peer in learned:
            learned.move_to_end(peer)
            return
        learned[peer] = None
        if len(learned) > MAX_LEARNED_PEERS:
            old, _ = learned.popitem(last=False)
            logger.info("forgetting MAVLink peer %s:%d (least recently heard)", *old)
        self._peers = self._configured_peers + list(learned)
        logger.info("new MAVLink peer %s:%d", *peer)

    def _from_ourselves(self, msg: mavlink2.MAVLink_message) -> bool:
        return (
            msg.get_srcSystem() == self._config.sysid
            and msg.get_srcComponent() == self._config.compid
        )

    def _targets_us(self, target_system: int, target_component: int) -> bool:
        return target_system in (0, self._config.sysid) and target_component in (
            0,
            self._config.compid,
        )

    def _command_targets_us(self, msg: mavlink2.MAVLink_message) -> bool:
        """Whether to execute and ACK a COMMAND_LONG/INT, after PX4's evaluate_target_ok.

        PX4 (mavlink_receiver.cpp) answers the autopilot-capabilities and protocol-version
        requests for any component of its system, every other command only when addressed to
        its own component or to all (0). A command for another component that PX4 has never
        seen (e.g. a camera, compid 100, where none is connected) is logged ("Ignore command")
        and left unanswered, never ACKed: PX4 PR #23870 (2024-11) removed the FAILED ACK that
        v1.15 and earlier sent, since the addressed component may answer itself. An ACK from
        us would not help a client anyway: MAVSDK only accepts an ACK whose sender is the
        command's target. Unlike PX4, target_system 0 (broadcast) is accepted, as before.
        Commands for another system are ignored.
        """
        if msg.target_system not in (0, self._config.sysid):
            return False
        return msg.command in _ANY_COMPONENT_COMMANDS or msg.target_component in (
            0,
            self._config.compid,
        )

    def _on_command(self, msg: mavlink2.MAVLink_message) -> None:
        if not self._command_targets_us(msg):
            if not self._forwarded:
                self.stats.commands_ignored += 1
            return
        self._replies.clear()
        reply = self._commands.handle(CommandRequest.from_message(msg))
        if reply.duplicate:
            self.stats.commands_duplicate += 1
        else:
            self.stats.commands_handled += 1
        self._send(
            mavlink2.MAVLink_command_ack_message(
                command=msg.command,
                result=reply.result,
                progress=0,
                result_param2=0,
                target_system=msg.get_srcSystem(),
                target_component=msg.get_srcComponent(),
            ),
            to=self._sender,
        )
        replies, self._replies = self._replies, []
        for message in replies:
            self._send(message)

    def _on_param_request_list(self, msg: mavlink2.MAVLink_message) -> None:
        if self._targets_us(msg.target_system, msg.target_component):
            self._params.handle_request_list()
            self._next_work_s = -_NEVER
            self.quiet_until_s = -_NEVER

    def _on_param_request_read(self, msg: mavlink2.MAVLink_message) -> None:
        if self._targets_us(msg.target_system, msg.target_component):
            self._params.handle_request_read(msg)

    def _on_param_set(self, msg: mavlink2.MAVLink_message) -> None:
        if self._targets_us(msg.target_system, msg.target_component):
            version = self._vehicle.params.version
            self._params.handle_set(msg)
            if self._vehicle.params.version != version:
                self._hub.param_changed(self._cursor, msg.param_id)

    def _on_heartbeat(self, msg: mavlink2.MAVLink_message) -> None:
        # PX4 counts only ground stations (type GCS) for the data-link-loss failsafe.
        if msg.type == mavlink2.MAV_TYPE_GCS:
            self._vehicle.gcs_heartbeat()
            self.presence.heartbeat(self._now_s, self._wall_clock_s())

    def _on_mission(
        self, handler: Callable[[mavlink2.MAVLink_message, tuple[int, int]], None]
    ) -> Callable[[mavlink2.MAVLink_message], None]:
        """Wrap a MissionProtocol handler: check the target, pass the sender's ids."""

        def handle(msg: mavlink2.MAVLink_message) -> None:
            if self._targets_us(msg.target_system, msg.target_component):
                handler(msg, (msg.get_srcSystem(), msg.get_srcComponent()))
                self._reschedule()

        return handle

    def _on_mission_set_current(self, msg: mavlink2.MAVLink_message) -> None:
        if self._targets_us(msg.target_system, msg.target_component):
            self._missions.handle_set_current(msg)
            self._mission_events((), force_current=True)

    def _mission_events(self, reached: Iterable[int], force_current: bool = False) -> None:
        """MISSION_ITEM_REACHED for completed items; MISSION_CURRENT when it changed."""
        for seq in reached:
            self._send(mavlink2.MAVLink_mission_item_reached_message(seq & 0xFFFF))
        status = self._vehicle.mission_status()
        if force_current or status != self._mission_status:
            self._mission_status = status
            self._emit(mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT)

    def _on_setpoint(self, msg: mavlink2.MAVLink_message) -> None:
        """SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT, SET_ATTITUDE_TARGET -> the vehicle."""
        if not self._targets_us(msg.target_system, msg.target_component):
            return
        vehicle = self._vehicle
        try:
            msg_id = msg.get_msgId()
            if msg_id == mavlink2.MAVLINK_MSG_ID_SET_ATTITUDE_TARGET:
                taken = vehicle.offboard_setpoint(decode_attitude(msg), LocalFrame.LOCAL_NED)
                reason = "a thrust alone without an attitude or rate setpoint"
            elif msg_id == mavlink2.MAVLINK_MSG_ID_SET_POSITION_TARGET_LOCAL_NED:
                taken = vehicle.offboard_setpoint(*decode_local(msg))
                reason = ""
            else:
                taken = vehicle.offboard_setpoint_global(decode_global(msg))
                reason = "no global origin or home yet"
        except SetpointError as exc:
            taken, reason = False, str(exc)
        if taken:
            self.stats.setpoints_received += 1
            return
        self.stats.setpoints_ignored += 1
        key = f"{msg.get_type()}: {reason}"
        if key not in self._setpoint_problems:
            self._setpoint_problems.add(key)
            logger.warning("ignoring %s (type_mask 0x%04x)", key, int(msg.type_mask))

    def _on_vision(self, msg: mavlink2.MAVLink_message) -> None:
        """VISION_POSITION_ESTIMATE / ODOMETRY -> the vehicle's external-vision input.

        Stamped with the arrival time: without a converged timesync offset PX4 stamps such
        samples with their arrival too (``sync_stamp``); EKF2_EV_DELAY covers the latency.
        """
        try:
            if msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_ODOMETRY:
                m = decode_odometry(msg)
            else:
                m = decode_vision_position_estimate(msg)
        except VisionError as exc:
            self.stats.vision_ignored += 1
            key = f"{msg.get_type()}: {exc}"
            if key not in self._vision_problems:
                self._vision_problems.add(key)
                logger.warning("ignoring %s", key)
            return
        self._vehicle.vision_measurement(
            self._now_us,
            m.position_ned_m,
            m.position_var_m2,
            m.yaw_rad,
            m.yaw_var_rad2,
            m.velocity_ned_m_s,
        )
        self.stats.vision_received += 1

    def _on_ping(self, msg: mavlink2.MAVLink_message) -> None:
        # As PX4: target 0/0 is a request to answer; a PING addressed to us is a reply to a
        # ping of ours (answering it could start a ping-pong between vehicles): its time_usec
        # is the simulation time we sent, which the peer has now read.
        config = self._config
        if msg.target_system == config.sysid and msg.target_component == config.compid:
            if self._ping_period_us > 0:
                self.presence.echoed(msg.time_usec / 1e6, self._now_s, self._wall_clock_s())
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

    def _on_timesync(self, msg: mavlink2.MAVLink_message) -> None:
        # As PX4 (mavlink_timesync): a request (tc1 == 0) is answered with our boot time in ns and
        # ts1 echoed; an answer to our own requests (tc1 > 0) needs no offset estimate here.
        if msg.tc1 == 0:
            self._send(messages.timesync_reply(msg, self._now_us * 1000))

    def _on_ftp(self, msg: mavlink2.MAVLink_message) -> None:
        if self._ftp is not None and self._targets_us(msg.target_system, msg.target_component):
            self._ftp.handle(msg)

    # --- CommandServices (called by the dispatcher) ------------------------------------------

    def request_message(self, msg_id: int) -> int:
        """MAV_CMD_REQUEST_MESSAGE: build ``msg_id`` now, send it after the ACK.

        DISTANCE_SENSOR: the latest reading of every range finder (denied without any).
        """
        if msg_id == mavlink2.MAVLINK_MSG_ID_DISTANCE_SENSOR:
            readings = latest_messages(self._telemetry().distance_sensors)
            self._replies.extend(readings)
            return ACCEPTED if readings else DENIED
        if msg_id not in messages.BUILDERS and msg_id != mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT:
            return DENIED
        message = self._build(msg_id)
        if message is None:
            return DENIED
        self._replies.append(message)
        return ACCEPTED

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL on one of our streams."""
        now_us = round(self._now_s * 1e6)
        if not self._streams.set_interval(msg_id, interval_us, now_us):
            return DENIED
        self._reschedule()
        return ACCEPTED

    def report_message_interval(self, msg_id: int) -> int:
        """MAV_CMD_GET_MESSAGE_INTERVAL: reply MESSAGE_INTERVAL (0 = not available)."""
        interval_us = self._streams.interval_us(msg_id) if self._streams.knows(msg_id) else 0
        self._replies.append(messages.message_interval(msg_id, interval_us))
        return ACCEPTED

    def home_alt_amsl_m(self) -> float | None:
        """Home altitude AMSL from this poll's snapshot; None without a home."""
        home = self._telemetry().home
        return None if home is None else home.alt_amsl_m
