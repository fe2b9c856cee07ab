"""The datagram format of node messaging: one msgpack-encoded envelope per UDP datagram.

An envelope is a msgpack array whose first element is the format version
(``FORMAT_VERSION``), followed by the fields of ``Envelope`` in declaration order:
``[version, src, dst, kind, topic, msg_id, reply_to, category, sent_s, attempt, body]``.
An array rather than a map keeps the per-message overhead small (about 25 bytes plus the
strings). ``decode`` accepts nothing else: any malformed datagram raises ``EnvelopeError``.

Times are in seconds of the sender's clock (simulated seconds under swarmsitl).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import msgpack

FORMAT_VERSION = 1
"""Version of the envelope layout; ``decode`` rejects any other."""
MAX_DATAGRAM_BYTES = 65507
"""Largest UDP payload over IPv4 (65535 - 8 UDP header - 20 IP header), bytes."""

Kind = Literal["msg", "request", "reply"]
Category = Literal["data", "control"]
KINDS: tuple[str, ...] = ("msg", "request", "reply")
"""Allowed values of ``Envelope.kind``."""
CATEGORIES: tuple[str, ...] = ("data", "control")
"""Allowed values of ``Envelope.category`` (seed 000's overhead = control bytes / all bytes)."""


class EnvelopeError(ValueError):
    """A datagram is not a valid envelope (not msgpack, wrong version, bad field)."""


class MessageTooLargeError(ValueError):
    """An envelope does not fit in one UDP datagram; nothing was sent."""

    def __init__(self, size_bytes: int, limit_bytes: int = MAX_DATAGRAM_BYTES) -> None:
        super().__init__(
            f"encoded message is {size_bytes} bytes, above the {limit_bytes}-byte datagram "
            "limit (UDP over IPv4); split the body or send it in chunks"
        )
        self.size_bytes = size_bytes
        self.limit_bytes = limit_bytes


@dataclass(slots=True)
class Envelope:
    """One message between nodes, as it travels in a datagram."""

    src: str
    """Node id of the sender."""
    dst: str
    """Node id of the receiver (group and broadcast sends are expanded to unicasts)."""
    kind: Kind
    """"msg" (one-way), "request" (expects a reply) or "reply"."""
    topic: str
    """What the message is about; receivers dispatch on it."""
    msg_id: int
    """Per-sender counter; a retransmitted request keeps its msg_id."""
    reply_to: int | None
    """For a reply: the msg_id of the request it answers; else None."""
    category: Category
    """"data" or "control" (requests, replies and retries are control by default)."""
    sent_s: float
    """Sender's clock when this copy was sent, s (simulated seconds under swarmsitl)."""
    attempt: int
    """Transmission number, 1 for the first copy; a reply echoes its request's attempt."""
    body: Any
    """Payload: anything msgpack encodes (dict, list, str, bytes, numbers, None); tuples and
    numpy arrays arrive as lists."""


# (name, accepted types, may be None) per field after the version, in order.
_FIELDS: tuple[tuple[str, tuple[type, ...], bool], ...] = (
    ("src", (str,), False),
    ("dst", (str,), False),
    ("kind", (str,), False),
    ("topic", (str,), False),
    ("msg_id", (int,), False),
    ("reply_to", (int,), True),
    ("category", (str,), False),
    ("sent_s", (float, int), False),
    ("attempt", (int,), False),
)


_KIND_SET = frozenset(KINDS)
_CATEGORY_SET = frozenset(CATEGORIES)


def encode(env: Envelope) -> bytes:
    """Encode an envelope to one datagram.

    Raises:
        MessageTooLargeError: the datagram would exceed ``MAX_DATAGRAM_BYTES``.
        TypeError: the body holds something msgpack cannot encode (the message names it).
    """
    data = msgpack.packb(
        [
            FORMAT_VERSION,
            env.src,
            env.dst,
            env.kind,
            env.topic,
            env.msg_id,
            env.reply_to,
            env.category,
            float(env.sent_s),
            env.attempt,
            env.body,
        ],
        use_bin_type=True,
        default=_to_msgpack,
    )
    if len(data) > MAX_DATAGRAM_BYTES:
        raise MessageTooLargeError(len(data))
    return data


def encode_fanout(template: Envelope, dsts: Sequence[str]) -> list[bytes]:
    """Encode one message to each of ``dsts`` (datagrams, in order; ``template.dst`` unused).

    Datagram i is ``encode`` of ``template`` with ``dst = dsts[i]`` and
    ``msg_id = template.msg_id + i``, byte for byte. A msgpack array is its header followed by
    its elements' encodings, so the fields common to every copy (the body above all) are
    encoded once and spliced around each copy's ``dst`` and ``msg_id``: a group send or a
    broadcast costs one body encoding, not one per recipient.

    Raises:
        MessageTooLargeError: a datagram would exceed ``MAX_DATAGRAM_BYTES`` (the first such).
        TypeError: the body holds something msgpack cannot encode (only if ``dsts`` is not empty).
    """
    if not dsts:
        return []
    packer = msgpack.Packer(use_bin_type=True, default=_to_msgpack)
    pack = packer.pack
    head = b"".join(
        (packer.pack_array_header(len(_FIELDS) + 2), pack(FORMAT_VERSION), pack(template.src))
    )
    between = pack(template.kind) + pack(template.topic)
    tail = b"".join(
        (
            pack(template.reply_to),
            pack(template.category),
            pack(float(template.sent_s)),
            pack(template.attempt),
            pack(template.body),
        )
    )
    out = []
    for msg_id, dst in enumerate(dsts, template.msg_id):
        data = b"".join((head, pack(dst), between, pack(msg_id), tail))
        if len(data) > MAX_DATAGRAM_BYTES:
            raise MessageTooLargeError(len(data))
        out.append(data)
    return out


def _to_msgpack(obj: Any) -> Any:
    """Convert numpy arrays and scalars (anything with ``tolist``) to lists / Python numbers."""
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(
        f"body: cannot encode a {type(obj).__name__} (use dict, list, str, bytes, numbers, "
        "None; numpy arrays and scalars are converted with tolist())"
    )


def decode(data: bytes) -> Envelope:
    """Decode one datagram.

    Raises:
        EnvelopeError: the datagram is not a valid envelope of this format version.
    """
    try:
        items = msgpack.unpackb(data, raw=False, use_list=True)
    except (ValueError, TypeError, OverflowError, msgpack.UnpackException) as exc:
        raise EnvelopeError(f"not a msgpack datagram: {exc}") from exc
    if not isinstance(items, list) or not items:
        raise EnvelopeError("envelope must be a non-empty msgpack array")
    if len(items) == len(_FIELDS) + 2:
        # The common case, checked in one expression (exact types: msgpack gives no subclasses,
        # and bool is not int here); anything off goes to the checks below, which say what.
        version, src, dst, kind, topic, msg_id, reply_to, category, sent_s, attempt, body = items
        if (
            type(version) is int
            and version == FORMAT_VERSION
            and type(src) is str
            and type(dst) is str
            and type(topic) is str
            and type(kind) is str
            and kind in _KIND_SET
            and type(category) is str
            and category in _CATEGORY_SET
            and type(msg_id) is int
            and msg_id >= 0
            and (reply_to is None or type(reply_to) is int)
            and type(attempt) is int
            and attempt >= 1
            and type(sent_s) in (float, int)
            and math.isfinite(sent_s)
        ):
            return Envelope(
                src, dst, kind, topic, msg_id, reply_to, category, float(sent_s), attempt, body
            )
    if type(items[0]) is not int or items[0] != FORMAT_VERSION:
        raise EnvelopeError(f"envelope format version {items[0]!r}, expected {FORMAT_VERSION}")
    if len(items) != len(_FIELDS) + 2:
        raise EnvelopeError(f"envelope has {len(items)} elements, expected {len(_FIELDS) + 2}")
    for (name, types, nullable), value in zip(_FIELDS, items[1:-1], strict=True):
        if value is None and nullable:
            continue
        if isinstance(value, bool) or not isinstance(value, types):
            raise EnvelopeError(f"envelope field {name!r} has type {type(value).__name__}")
    _, src, dst, kind, topic, msg_id, reply_to, category, sent_s, attempt, body = items
    if kind not in KINDS:
        raise EnvelopeError(f"envelope field 'kind' is {kind!r}, expected one of {KINDS}")
    if category not in CATEGORIES:
        raise EnvelopeError(
            f"envelope field 'category' is {category!r}, expected one of {CATEGORIES}"
        )
    if msg_id < 0 or attempt < 1:
        raise EnvelopeError("envelope fields 'msg_id' must be >= 0 and 'attempt' >= 1")
    if not math.isfinite(sent_s):
        raise EnvelopeError(f"envelope field 'sent_s' is {sent_s!r}, expected a finite time")
    return Envelope(src, dst, kind, topic, msg_id, reply_to, category, float(sent_s), attempt, body)


def route_of(data: bytes) -> tuple[str, str]:
    """``(src, dst)`` of a datagram without decoding its body (for a datagram router).

    Raises:
        EnvelopeError: the datagram does not start like an envelope of this version.
    """
    unpacker = msgpack.Unpacker(raw=False)
    unpacker.feed(data)
    try:
        if unpacker.read_array_header() != len(_FIELDS) + 2:
            raise EnvelopeError("not an envelope array")
        version, src, dst = unpacker.unpack(), unpacker.unpack(), unpacker.unpack()
    except (ValueError, TypeError, OverflowError, msgpack.UnpackException) as exc:
        raise EnvelopeError(f"not an envelope: {exc}") from exc
    if type(version) is not int or version != FORMAT_VERSION:
        raise EnvelopeError(f"envelope format version {version!r}, expected {FORMAT_VERSION}")
    if not isinstance(src, str) or not isinstance(dst, str):
        raise EnvelopeError("envelope fields 'src' and 'dst' must be strings")
    return src, dst
