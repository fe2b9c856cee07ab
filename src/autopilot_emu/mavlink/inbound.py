"""Datagrams into one MAVLink link: parsing, admission, peer learning, forwarding, dispatch.

Each datagram is parsed into frames; a frame cut short by the end of a UDP datagram is dropped
(a serial link's byte stream carries it over to the next read). On a signed link only correctly
signed frames are admitted (:mod:`autopilot_emu.mavlink.signing`). An admitted frame is logged
to the tlog, makes its sender a peer, is relayed to the vehicle's other links when it is for
another component or system (:mod:`autopilot_emu.mavlink.forwarding`), and is handed to the
handler of its message id unless it is our own frame looped back. Malformed input is counted in
the link's stats and logged, never raised; so is an exception of a handler.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Callable, Mapping

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.endpoint_config import EndpointConfig, EndpointStats
from autopilot_emu.mavlink.forwarding import required_target, should_forward
from autopilot_emu.mavlink.link_clock import LinkClock
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.signing import LinkSigner, Verdict
from autopilot_emu.mavlink.tlog import TlogWriter
from autopilot_emu.mavlink.transmit import Address, Transmitter
from autopilot_emu.mavlink.transport import Transport

logger = logging.getLogger(__name__)

MAX_DATAGRAMS_PER_POLL = 64
"""Datagrams drained per poll; the rest wait for the next poll."""
MAX_DATAGRAM_BYTES = 65535

Handler = Callable[[mavlink2.MAVLink_message], None]
_BAD_DATA = mavlink2.MAVLINK_MSG_ID_BAD_DATA
_UNKNOWN = mavlink2.MAVLINK_MSG_ID_UNKNOWN


class Receiver:
    """Takes one link's datagrams apart and hands each admitted frame to its handler.

    Args:
        config: the link's ids, modelled link and forwarding switch.
        stream: the link is a byte stream (serial): a frame may span reads.
        handlers: message id -> handler (the endpoint's table).
        hub: the vehicle's shared side (forwarding group, fresh snapshot after input).
        tx: where learned peers go, and how frames forwarded to this link leave it.
        stats: the link's counters.
        clock: simulation time of the poll (tlog stamps).
        tlog: where every admitted frame is logged; None: no log.
        signer: judges the signatures on a signed link; None: every frame is admitted.
    """

    def __init__(
        self,
        config: EndpointConfig,
        stream: bool,
        handlers: Mapping[int, Handler],
        hub: LinkHub,
        tx: Transmitter,
        stats: EndpointStats,
        clock: LinkClock,
        tlog: TlogWriter | None,
        signer: LinkSigner | None,
    ) -> None:
        self._sysid = config.sysid
        self._compid = config.compid
        self._shaper = config.shaper
        self._stream = stream
        self._handlers = handlers
        self._hub = hub
        self._tx = tx
        self._stats = stats
        self._clock = clock
        self._tlog = tlog
        self._signer = signer
        self._mav = mavlink2.MAVLink(None, srcSystem=config.sysid, srcComponent=config.compid)
        """The parser of received frames."""
        self._mav.robust_parsing = True
        self.sender: Address | None = None
        """Address of the datagram being handled (COMMAND_ACKs go back to it alone)."""
        self.forwarded = False
        """The frame being handled was relayed to the vehicle's other links."""
        self._forward_member: int | None = None

    def join_forwarding(self) -> None:
        """Relay to and from the vehicle's other links with forwarding on (PX4's ``-f``)."""
        self._forward_member = self._hub.forwarding.join(self._tx.relay)

    def leave_forwarding(self) -> None:
        """Stop relaying (the link closes). Safe to call twice."""
        if self._forward_member is not None:
            self._hub.forwarding.leave(self._forward_member)
            self._forward_member = None

    def drain(self, sock: socket.socket | Transport) -> None:
        """Read up to MAX_DATAGRAMS_PER_POLL datagrams: handle them, or hand them to the shaper."""
        shaper = self._shaper
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            try:
                data, address = sock.recvfrom(MAX_DATAGRAM_BYTES)
            except BlockingIOError:
                break
            except OSError as exc:
                self._stats.recv_errors += 1
                logger.debug("recvfrom failed: %s", exc)
                break
            if shaper is None:
                self.datagram(data, address)
            else:
                shaper.inbound(self._clock.now_s, data, address)

    def datagram(self, data: bytes, address: Address) -> None:
        """Parse one datagram and handle each frame in it."""
        stats = self._stats
        stats.datagrams_received += 1
        parser = self._mav
        try:
            frames = parser.parse_buffer(data) or []
        except Exception as exc:
            stats.parse_errors += 1
            logger.debug("unparsable datagram from %s: %s", address, exc)
            frames = []
        if parser.buf_len() > 0 and not self._stream:
            # A frame cut short by the end of the datagram: drop it rather than let it swallow
            # the start of the next datagram.
            stats.parse_errors += 1
            logger.debug("truncated frame from %s (%d bytes)", address, parser.buf_len())
            parser.buf = bytearray()
            parser.buf_index = 0
            parser.expected_length = mavlink2.HEADER_LEN_V1 + 2
        learned = False
        signer = self._signer
        self.sender = address
        for msg in frames:
            msg_id = msg.get_msgId()
            if msg_id == _BAD_DATA:
                stats.parse_errors += 1
                logger.debug("bad data from %s: %s", address, getattr(msg, "reason", ""))
                continue
            if signer is not None and not self._admit(signer, msg, address):
                continue
            stats.frames_received += 1
            if msg_id == _UNKNOWN:
                # Not logged: without the dialect's CRC extra its checksum cannot be verified.
                stats.unknown_messages += 1
                continue
            if self._tlog is not None:
                self._tlog.write(self._clock.now_s, bytes(msg.get_msgbuf()))
            if not learned:
                self._tx.learn_peer(address)
                learned = True
            self.forwarded = False
            member = self._forward_member
            if member is not None:
                self._hub.forwarding.heard(member, msg.get_srcSystem(), msg.get_srcComponent())
            if member is not None and should_forward(msg, self._sysid, self._compid):
                frame = bytes(msg.get_msgbuf())
                target = required_target(msg, self._sysid)
                if self._hub.forwarding.forward(member, frame, target):
                    stats.frames_forwarded += 1
                    self.forwarded = True
            handler = self._handlers.get(msg_id)
            if handler is None or (
                msg.get_srcSystem() == self._sysid and msg.get_srcComponent() == self._compid
            ):
                continue  # nobody handles it, or our own frame looped back
            try:
                handler(msg)
            except Exception:
                stats.handler_errors += 1
                logger.exception("error handling %s from %s", msg.get_type(), address)
            self._hub.touched()

    def _admit(self, signer: LinkSigner, msg: mavlink2.MAVLink_message, address: Address) -> bool:
        """Signed link: whether to handle ``msg``; rejections counted and logged (rate-limited).

        A rejected frame is not handled, logged to the tlog, forwarded, nor does its sender
        become a peer.
        """
        verdict = signer.check(msg.get_msgbuf())
        if verdict is Verdict.SIGNED:
            return True
        stats = self._stats
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
