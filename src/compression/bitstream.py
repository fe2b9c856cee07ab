"""The stream format: a versioned header, the escaped latent values and the ANS words, with a CRC.

Layout (big-endian header, 28 bytes)::

    magic     4 s   b"SWAE"
    version   B     FORMAT_VERSION
    model_id  8 s   first 8 bytes of the SHA-256 of the model files that wrote it
    level     B     compression level (compression.LEVELS)
    height    H     image rows
    width     H     image columns
    length    I     payload bytes that follow the header
    crc32     I     CRC-32 of the header's first 24 bytes and the payload
    payload:  escape count (u32 LE), the escaped values (zig-zag LEB128 varints), ANS words (u32 LE)

The CRC is what turns a flipped bit into an error instead of a silently different picture: an
entropy decoder reads any bytes as *some* latent.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

from compression.errors import ModelMismatchError, StreamError

MAGIC = b"SWAE"
FORMAT_VERSION = 1
_HEADER = struct.Struct(">4sB8sBHHII")
HEADER_BYTES = _HEADER.size


@dataclass(frozen=True)
class StreamHeader:
    """What a stream says about itself before any of it is decoded."""

    version: int
    model_id: bytes
    level: int
    height: int
    width: int
    payload_bytes: int


@dataclass(frozen=True)
class Payload:
    """The entropy-coded part: ANS words and the latent values the tables could not code."""

    escapes: np.ndarray  # int64, channel-major order of appearance
    words: np.ndarray  # uint32


def pack(model_id: bytes, level: int, height: int, width: int, payload: Payload) -> bytes:
    """The complete stream of one image."""
    body = (
        struct.pack("<I", payload.escapes.size)
        + _varints(payload.escapes)
        + payload.words.astype("<u4").tobytes()
    )
    head = _HEADER.pack(MAGIC, FORMAT_VERSION, model_id, level, height, width, len(body), 0)[:-4]
    crc = zlib.crc32(body, zlib.crc32(head))
    return head + struct.pack(">I", crc) + body


def read_header(data: bytes) -> StreamHeader:
    """The header of a stream, checked for magic, length and CRC (not for the model)."""
    if not isinstance(data, bytes | bytearray | memoryview):
        raise StreamError(f"a stream is bytes, got {type(data).__name__}")
    data = bytes(data)
    if len(data) < HEADER_BYTES:
        raise StreamError(
            f"stream truncated: {len(data)} bytes, the header alone is {HEADER_BYTES}"
        )
    magic, version, model_id, level, height, width, length, crc = _HEADER.unpack_from(data)
    if magic != MAGIC:
        raise StreamError(f"not a swarmsitl codec stream (magic {magic!r}, expected {MAGIC!r})")
    if len(data) != HEADER_BYTES + length:
        raise StreamError(
            f"stream truncated or padded: header announces {length} payload bytes, "
            f"{len(data) - HEADER_BYTES} follow"
        )
    if zlib.crc32(data[HEADER_BYTES:], zlib.crc32(data[: HEADER_BYTES - 4])) != crc:
        raise StreamError("stream corrupted: CRC-32 mismatch")
    if version != FORMAT_VERSION:
        raise ModelMismatchError(
            f"stream format version {version}; this decoder reads version {FORMAT_VERSION}"
        )
    if height == 0 or width == 0:
        raise StreamError(f"stream announces an empty image ({height}x{width})")
    return StreamHeader(version, model_id, level, height, width, length)


def unpack(data: bytes) -> tuple[StreamHeader, Payload]:
    """Header and payload of a stream (raises ``StreamError`` / ``ModelMismatchError``)."""
    header = read_header(data)
    body = memoryview(bytes(data))[HEADER_BYTES:]
    if len(body) < 4:
        raise StreamError("stream corrupted: payload shorter than its escape count")
    (count,) = struct.unpack_from("<I", body)
    escapes, end = _read_varints(body, 4, count)
    rest = len(body) - end
    if rest % 4:
        raise StreamError("stream corrupted: entropy-coded words are not whole 32-bit words")
    words = np.frombuffer(body[end:], dtype="<u4").astype(np.uint32)
    return header, Payload(escapes=escapes, words=words)


def _varints(values: np.ndarray) -> bytes:
    out = bytearray()
    for v in values.tolist():
        z = (v << 1) ^ (v >> 63)  # zig-zag: small magnitudes of either sign -> small codes
        while True:
            byte = z & 0x7F
            z >>= 7
            if z:
                out.append(byte | 0x80)
            else:
                out.append(byte)
                break
    return bytes(out)


def _read_varints(body: memoryview, start: int, count: int) -> tuple[np.ndarray, int]:
    values = np.empty(count, dtype=np.int64)
    pos = start
    for i in range(count):
        z, shift = 0, 0
        while True:
            if pos >= len(body) or shift > 63:
                raise StreamError("stream corrupted: escaped latent values run past the payload")
            byte = body[pos]
            pos += 1
            z |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                break
        values[i] = (z >> 1) ^ -(z & 1)
    return values, pos
