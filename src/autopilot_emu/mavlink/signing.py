"""MAVLink 2 message signing of a vehicle's links, as PX4 (``mavlink_sign_control``) does it.

With a secret key every frame a link sends is signed and only correctly signed frames are
accepted: PX4 with ``MAV_SIGN_CFG`` = 2 (signatures required on every link; the emulator has
no USB link, the one kind PX4's ``MAV_SIGN_CFG`` = 1 exempts).
The wire format is MAVLink 2's (message_signing in the MAVLink developer guide):

* the header's incompat flags carry 0x01 (signed), so the CRC covers that flag;
* 13 bytes follow the CRC: the link id (1 byte), a 48-bit timestamp in 10 us units since
  2015-01-01 00:00 UTC (little-endian), and the first 6 bytes of
  SHA-256(key + header + payload + CRC + link id + timestamp).

Timestamps: a link signs with the wall clock (the spec's reference, so that peers on other
machines accept it), at least one more than its previous timestamp and never behind the newest
timestamp it accepted (the MAVLink C library's rule). A received frame is accepted when its
signature verifies and its timestamp is newer than the last one accepted from the same
(link id, sysid, compid) stream; a stream not seen before is accepted unless its timestamp is
more than one minute behind the link's own. The streams table is shared by a vehicle's links
(:class:`SigningStreams`, held by the link hub; PX4 shares one table between its MAVLink
instances), so a frame captured on one link cannot be replayed into another. As in the C
library (and unlike pymavlink's ``check_signature``, which records a stream's timestamp before
checking the signature) a stream's timestamp only moves on a frame whose signature verified:
a forged frame with a far-future timestamp cannot lock a genuine client out.

Accepted unsigned, as PX4's ``accept_unsigned``: RADIO_STATUS, ADSB_VEHICLE and COLLISION (a
radio modem and traffic receivers cannot sign). Everything else unsigned, including every
MAVLink 1 frame, is rejected, as is a signed frame whose signature does not verify (another
key) or whose timestamp is old (a replay).

Keys: 32 bytes, from a key file (:func:`load_key_file`: 64 hexadecimal characters, or exactly
32 raw bytes) or a passphrase (:func:`key_from_passphrase`: SHA-256 of its UTF-8 bytes, as
MAVProxy's ``signing setup PASSPHRASE`` and ``signing key PASSPHRASE`` derive it). An all-zero
key is refused: SETUP_SIGNING uses it to switch signing off.
"""

from __future__ import annotations

import hashlib
import logging
import string
import time
from collections import OrderedDict
from collections.abc import Callable
from enum import Enum
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing

logger = logging.getLogger(__name__)

KEY_BYTES = 32
"""Length of a MAVLink 2 secret key."""
SIGNATURE_BYTES = 13
"""Link id (1), timestamp (6), truncated SHA-256 (6)."""
IFLAG_SIGNED = 0x01
"""MAVLINK_IFLAG_SIGNED: the incompat-flags bit of a signed frame."""
EPOCH_2015_UNIX_S = 1_420_070_400
"""2015-01-01 00:00 UTC, the origin of signing timestamps, Unix seconds."""
TIMESTAMP_UNITS_PER_S = 100_000
"""Signing timestamps count 10 us units."""
NEW_STREAM_MAX_AGE = 60 * TIMESTAMP_UNITS_PER_S
"""A new stream's first timestamp may be at most one minute behind the link's (C library)."""
MAX_STREAMS = 64
"""Streams remembered per vehicle; when more appear, the one updated least recently is dropped
(the C library refuses new streams beyond 16 instead, which would lock out a client that
reconnects with a new link id after 16 reconnections)."""
UNSIGNED_ACCEPTED = frozenset(
    {
        mavlink2.MAVLINK_MSG_ID_RADIO_STATUS,
        mavlink2.MAVLINK_MSG_ID_ADSB_VEHICLE,
        mavlink2.MAVLINK_MSG_ID_COLLISION,
    }
)
"""Messages accepted without a signature (PX4 mavlink_sign_control.cpp, ``unsigned_messages``)."""
REJECT_LOG_INTERVAL_S = 10.0
"""A link logs rejected frames at most once per this many wall seconds (with a count)."""

_sha256 = hashlib.sha256
_MAGIC_V2 = 0xFD


class SigningKeyError(ValueError):
    """A key file or passphrase that cannot be a MAVLink 2 signing key (the message says why)."""


def key_from_passphrase(passphrase: str) -> bytes:
    """The 32-byte key of ``passphrase``: SHA-256 of its UTF-8 bytes (MAVProxy's derivation).

    Raises:
        SigningKeyError: the passphrase is empty.
    """
    if not passphrase:
        raise SigningKeyError("the signing passphrase is empty")
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


def parse_key(data: bytes, source: str = "key") -> bytes:
    """The key held by ``data``: 64 hex characters (surrounding whitespace ignored) or 32 bytes.

    Raises:
        SigningKeyError: anything else, or an all-zero key; the message names ``source``.
    """
    text = data.strip()
    if len(text) == 2 * KEY_BYTES and all(chr(c) in string.hexdigits for c in text):
        key = bytes.fromhex(text.decode("ascii"))
    elif len(data) == KEY_BYTES:
        key = bytes(data)
    else:
        raise SigningKeyError(
            f"{source}: expected 64 hexadecimal characters (e.g. the output of "
            f"`openssl rand -hex 32`) or exactly {KEY_BYTES} raw bytes, got {len(data)} bytes"
        )
    if not any(key):
        raise SigningKeyError(f"{source}: the all-zero key switches signing off; use another")
    return key


def load_key_file(path: Path) -> bytes:
    """Read a signing key file (see :func:`parse_key`).

    Raises:
        SigningKeyError: the file cannot be read or holds no valid key.
    """
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise SigningKeyError(f"{path}: cannot read the signing key file ({exc.strerror})") from exc
    return parse_key(data, str(path))


_NS_PER_UNIT = 1_000_000_000 // TIMESTAMP_UNITS_PER_S
_EPOCH_2015_UNITS = EPOCH_2015_UNIX_S * TIMESTAMP_UNITS_PER_S


def timestamp_now(unix_time_ns: int) -> int:
    """The signing timestamp of Unix time ``unix_time_ns``, 10 us units since 2015."""
    return max(0, unix_time_ns // _NS_PER_UNIT - _EPOCH_2015_UNITS)


class Verdict(Enum):
    """What a signed link makes of a received frame."""

    SIGNED = "signed"
    """Signature verified, timestamp new: accepted."""
    UNSIGNED_ALLOWED = "unsigned, allowed"
    """Unsigned but one of :data:`UNSIGNED_ACCEPTED`: accepted."""
    UNSIGNED = "unsigned"
    """Unsigned (or MAVLink 1): rejected."""
    BAD_SIGNATURE = "bad signature"
    """The signature does not verify (another key, or a tampered frame): rejected."""
    REPLAY = "old timestamp"
    """Signature fine, timestamp not newer than its stream's (or a stale new stream): rejected."""

    @property
    def accepted(self) -> bool:
        """Whether the frame is handled."""
        return self in (Verdict.SIGNED, Verdict.UNSIGNED_ALLOWED)


class SigningStreams:
    """The signing state a vehicle's links share: accepted streams' timestamps, link ids.

    Args:
        key: the 32-byte secret key of the vehicle's links.
    """

    def __init__(self, key: bytes) -> None:
        if len(key) != KEY_BYTES:
            raise SigningKeyError(f"a signing key has {KEY_BYTES} bytes, got {len(key)}")
        self.key = bytes(key)
        self.last: OrderedDict[tuple[int, int, int], int] = OrderedDict()
        """Newest accepted timestamp per (link id, sysid, compid), least recently updated first."""
        self._next_link_id = 0

    def new_link_id(self) -> int:
        """Link id of the vehicle's next link (PX4: its MAVLink instance number)."""
        link_id = self._next_link_id
        self._next_link_id = (link_id + 1) & 0xFF
        return link_id


class LinkSigner:
    """Signs one link's frames and judges the frames it receives.

    Args:
        streams: the vehicle's shared signing state (key, streams).
        unix_time_ns: wall clock of the timestamps, Unix ns (injectable for tests).
        monotonic_s: clock of the rate limit of rejection log lines.
    """

    def __init__(
        self,
        streams: SigningStreams,
        unix_time_ns: Callable[[], int] = time.time_ns,
        monotonic_s: Callable[[], float] = time.monotonic,
    ) -> None:
        self._streams = streams
        self._key = streams.key
        self.link_id = streams.new_link_id()
        self._link_id_byte = bytes((self.link_id,))
        self._unix_time_ns = unix_time_ns
        self._monotonic_s = monotonic_s
        self.timestamp = timestamp_now(unix_time_ns())
        """The newest timestamp this link signed with or accepted, 10 us units since 2015."""
        self._next_log_s = -float("inf")
        self._unlogged = 0

    def sign(self, frame: bytes) -> bytes:
        """``frame`` (MAVLink 2, incompat flag 0x01 set before its CRC) with its signature."""
        timestamp = self._unix_time_ns() // _NS_PER_UNIT - _EPOCH_2015_UNITS
        if timestamp <= self.timestamp:
            timestamp = self.timestamp + 1
        self.timestamp = timestamp
        signed = frame + self._link_id_byte + timestamp.to_bytes(6, "little")
        return signed + _sha256(self._key + signed).digest()[:6]

    def encode(self, message: mavlink2.MAVLink_message, seq: int, sysid: int, compid: int) -> bytes:
        """:func:`framing.encode`, signed."""
        return self.sign(framing.encode(message, seq, sysid, compid, IFLAG_SIGNED))

    def encode_fields(
        self, fmt: framing.FieldsFormat, values: tuple, seq: int, sysid: int, compid: int
    ) -> bytes:
        """:func:`framing.encode_fields` (the hot streams' fast path), signed."""
        return self.sign(framing.encode_fields(fmt, values, seq, sysid, compid, IFLAG_SIGNED))

    def check(self, frame: bytes | bytearray) -> Verdict:
        """Judge one received frame (CRC already checked), updating its stream if accepted."""
        ids = framing.source_and_msgid(frame)
        if ids is None:  # not a MAVLink frame: nothing to judge it by
            return Verdict.UNSIGNED
        sysid, compid, msg_id = ids
        # MAVLink 1 cannot be signed
        signed = frame[0] == _MAGIC_V2 and bool(frame[2] & IFLAG_SIGNED)
        if not signed or len(frame) < SIGNATURE_BYTES + 12:
            return Verdict.UNSIGNED_ALLOWED if msg_id in UNSIGNED_ACCEPTED else Verdict.UNSIGNED
        body = bytes(frame[:-6])
        if hashlib.sha256(self._key + body).digest()[:6] != bytes(frame[-6:]):
            return Verdict.BAD_SIGNATURE
        link_id = frame[-13]
        timestamp = int.from_bytes(frame[-12:-6], "little")
        key = (link_id, sysid, compid)
        streams = self._streams.last
        last = streams.get(key)
        if last is None:
            if timestamp + NEW_STREAM_MAX_AGE < self.timestamp:
                return Verdict.REPLAY
            if len(streams) >= MAX_STREAMS:
                streams.popitem(last=False)
        elif timestamp <= last:
            return Verdict.REPLAY
        streams[key] = timestamp
        streams.move_to_end(key)
        if timestamp > self.timestamp:
            self.timestamp = timestamp
        return Verdict.SIGNED

    def log_rejection(self, verdict: Verdict, msg_type: str, address: tuple[str, int]) -> None:
        """Log a rejected frame: at most one line per REJECT_LOG_INTERVAL_S, with a count."""
        now = self._monotonic_s()
        if now < self._next_log_s:
            self._unlogged += 1
            return
        self._next_log_s = now + REJECT_LOG_INTERVAL_S
        more = f" (and {self._unlogged} more rejected frames)" if self._unlogged else ""
        self._unlogged = 0
        logger.warning(
            "signed link %d: rejected %s from %s:%d: %s%s",
            self.link_id,
            msg_type,
            address[0],
            address[1],
            verdict.value,
            more,
        )
