"""What one MAVLink endpoint is configured with, and what it counts.

:class:`EndpointConfig` is one link's addresses, identity, stream profile and options (a .tlog, an
FTP root, a data-rate limit, a modelled link, a signing key); :class:`EndpointStats` the counters
of what the link received, sent, relayed and refused. Both are re-exported by
:mod:`autopilot_emu.mavlink.endpoint`.
"""

from __future__ import annotations

import errno
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from autopilot_emu.mavlink.shaping import LinkShaper
from autopilot_emu.mavlink.signing import KEY_BYTES
from autopilot_emu.mavlink.streams import StreamProfile


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
    read (``harness.run.lockstep``)."""

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
