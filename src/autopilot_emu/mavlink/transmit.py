"""Frames out of one MAVLink link: framing, the peers they go to, relaying, the modelled link.

Every frame goes to the configured peers and to every address MAVLink has been received from
(:meth:`Transmitter.learn_peer`), as PX4 does, except a COMMAND_ACK, which goes to the address
the command came from alone. Frames another link of the vehicle received are relayed unchanged
(:meth:`Transmitter.relay`). With a :class:`~autopilot_emu.mavlink.shaping.LinkShaper` the
frames wait for the modelled link; with a tlog each is logged; with a signer each is signed.
Errors while sending are counted and otherwise ignored.
"""

from __future__ import annotations

import logging
import socket
from collections import OrderedDict

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing
from autopilot_emu.mavlink.endpoint_config import EndpointConfig, EndpointStats
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.signing import LinkSigner
from autopilot_emu.mavlink.streams import StreamScheduler
from autopilot_emu.mavlink.tlog import TlogWriter
from autopilot_emu.mavlink.transport import Transport

logger = logging.getLogger(__name__)

MAX_LEARNED_PEERS = 16
"""Remote addresses remembered from received traffic, beyond the configured peers; when more
talk to the vehicle, the one heard from least recently is forgotten (it is re-learned as soon as
it sends again, so every sender always gets its replies)."""
MAX_HELD_HEARTBEATS = 8
"""Other components' HEARTBEATs a link holds for its next own frame; older ones are dropped."""

Address = tuple[str, int]
_HEARTBEAT = mavlink2.MAVLINK_MSG_ID_HEARTBEAT


def resolve(host: str, port: int) -> Address:
    """(host, port) -> (IPv4 address, port) as recvfrom reports addresses."""
    info = socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
    address = info[0][4]
    return (address[0], address[1])


class Transmitter:
    """Sends one link's frames: sequence numbers, signing, peers, modelled link and tlog.

    The endpoint opens the socket and the tlog after the link's other parts exist, and sets
    :attr:`sock` and :attr:`tlog` then.

    Args:
        config: the link's ids and modelled link (``config.shaper``).
        configured_peers: addresses every frame goes to, before any learned one.
        streams: the link's streams (is its own HEARTBEAT on? See :meth:`relay`).
        stats: the link's counters.
        clock: simulation time of the poll (modelled link, tlog stamps).
        signer: signs every frame this link frames; None: unsigned.
    """

    def __init__(
        self,
        config: EndpointConfig,
        configured_peers: list[Address],
        streams: StreamScheduler,
        stats: EndpointStats,
        clock: LinkClock,
        signer: LinkSigner | None,
    ) -> None:
        self.sock: socket.socket | Transport | None = None
        """The socket or serial transport; None before it is open and once it is closed."""
        self.tlog: TlogWriter | None = None
        """Where every frame sent is logged; None: no log."""
        self._sysid = config.sysid
        self._compid = config.compid
        self._shaper = config.shaper
        self._streams = streams
        self._stats = stats
        self._clock = clock
        self._encode = framing.encode if signer is None else signer.encode
        self._encode_fields = framing.encode_fields if signer is None else signer.encode_fields
        self._seq = 0
        """Sequence number of the next frame sent."""
        self.bytes_out = 0
        """Bytes of every frame this link sent."""
        self._configured_peers = configured_peers
        self._learned_peers: OrderedDict[Address, None] = OrderedDict()
        self.peers = list(configured_peers)
        """Addresses frames are sent to: configured peers, then learned ones."""
        self._held_heartbeats: list[bytes] = []
        """Other components' HEARTBEATs waiting for this link's next own frame (:meth:`relay`)."""

    def send(self, message: mavlink2.MAVLink_message, to: Address | None = None) -> None:
        """Frame ``message`` with our ids and the next sequence number; send it to every peer.

        ``to``: to that address alone (see :meth:`transmit`).
        """
        try:
            frame = self._encode(message, self._seq, self._sysid, self._compid)
        except Exception:
            self._stats.encode_errors += 1
            logger.exception("cannot pack %s", message.get_type())
            return
        self._seq = (self._seq + 1) & 0xFF
        self._stats.frames_sent += 1
        self.bytes_out += len(frame)
        self.transmit(frame, to)
        if self._held_heartbeats and to is None:  # after a frame every peer got
            self._release_heartbeats()

    def send_fields(self, msg_id: int, fmt: framing.FieldsFormat, values: tuple) -> None:
        """Frame a hot stream's field values (``messages.FIELDS``) and send it to every peer.

        The same frame as :meth:`send` of the message, without the pymavlink object.
        """
        try:
            frame = self._encode_fields(fmt, values, self._seq, self._sysid, self._compid)
        except Exception:
            self._stats.encode_errors += 1
            logger.exception("cannot build message %d", msg_id)
            return
        self._seq = (self._seq + 1) & 0xFF
        self._stats.frames_sent += 1
        self.bytes_out += len(frame)
        sock = self.sock
        if self._shaper is not None or self.tlog is not None or sock is None:
            self.transmit(frame)
        else:
            for peer in self.peers:  # transmit's work on an unshaped link without a tlog
                try:
                    sock.sendto(frame, peer)
                except OSError:
                    self._stats.send_errors += 1
        if self._held_heartbeats:
            self._release_heartbeats()

    def relay(self, frame: bytes) -> None:
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
            and ids[0] == self._sysid
            and ids[1] != self._compid
            and ids[2] == _HEARTBEAT
            and self._streams.interval_us(_HEARTBEAT) > 0
        ):
            if len(self._held_heartbeats) >= MAX_HELD_HEARTBEATS:
                del self._held_heartbeats[0]
            self._held_heartbeats.append(frame)
            return
        self._stats.frames_relayed += 1
        self.transmit(frame)

    def _release_heartbeats(self) -> None:
        """Relay the held HEARTBEATs (see :meth:`relay`), right after one of our own frames."""
        held, self._held_heartbeats = self._held_heartbeats, []
        for frame in held:
            self._stats.frames_relayed += 1
            self.transmit(frame)

    def transmit(self, frame: bytes, to: Address | None = None) -> None:
        """Send an encoded frame to every peer (through the shaper, if any) and log it.

        ``to``: to that peer alone (a COMMAND_ACK to the client that sent the command), unless
        the link is modelled: a UART or radio carries every byte to its far end, whoever asked.
        """
        if self._shaper is None:
            self.sendto_peers(frame, to)
        else:
            self._shaper.outbound(self._clock.now_s, frame)
        if self.tlog is not None:
            self.tlog.write(self._clock.now_s, frame)

    def sendto_peers(self, frame: bytes, to: Address | None = None) -> None:
        """Write a frame to the socket: to every peer, or to ``to`` alone."""
        sock = self.sock
        if sock is not None:
            for peer in self.peers if to is None else (to,):
                try:
                    sock.sendto(frame, peer)
                except OSError:
                    self._stats.send_errors += 1

    def learn_peer(self, address: Address) -> None:
        """MAVLink arrived from ``address``: send to it from now on (least recently heard last)."""
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
        self.peers = self._configured_peers + list(learned)
        logger.info("new MAVLink peer %s:%d", *peer)
