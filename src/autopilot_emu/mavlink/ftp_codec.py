"""The payload of FILE_TRANSFER_PROTOCOL (110) as PX4 and QGroundControl lay it out.

The message's 251-byte ``payload`` field carries a 12-byte little-endian header and up to
:data:`MAX_DATA_LENGTH` bytes of data (PX4 ``MavlinkFTP::PayloadHeader``)::

    offset  size  field
    0       2     seq_number      request: the client's number; reply: request's + 1
    2       1     session         file session the request refers to
    3       1     opcode          Opcode (a command, or ACK / NAK in replies)
    4       1     size            number of valid bytes in data
    5       1     req_opcode      replies: the opcode answered
    6       1     burst_complete  BurstReadFile replies: 1 on the last packet of a burst
    7       1     padding
    8       4     offset          file offset (read, write, burst) or entry index (list)
    12      239   data            path, file bytes, or for a NAK the ErrorCode (+ errno)

Pure functions only: no I/O, no MAVLink framing.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from enum import IntEnum

PAYLOAD_LENGTH = 251
"""Length of FILE_TRANSFER_PROTOCOL.payload, bytes."""
HEADER = struct.Struct("<HBBBBBBI")
MAX_DATA_LENGTH = PAYLOAD_LENGTH - HEADER.size
"""Largest data block of one message (PX4 ``kMaxDataLength``), bytes: 239."""


class Opcode(IntEnum):
    """Commands a client sends and the two reply opcodes (PX4 ``MavlinkFTP::Opcode``)."""

    NONE = 0
    TERMINATE_SESSION = 1
    RESET_SESSIONS = 2
    LIST_DIRECTORY = 3
    OPEN_FILE_RO = 4
    READ_FILE = 5
    CREATE_FILE = 6
    WRITE_FILE = 7
    REMOVE_FILE = 8
    CREATE_DIRECTORY = 9
    REMOVE_DIRECTORY = 10
    OPEN_FILE_WO = 11
    TRUNCATE_FILE = 12
    RENAME = 13
    CALC_FILE_CRC32 = 14
    BURST_READ_FILE = 15
    ACK = 128
    NAK = 129


class ErrorCode(IntEnum):
    """NAK codes in data[0] (PX4 ``MavlinkFTP::ErrorCode``)."""

    NONE = 0
    FAIL = 1
    FAIL_ERRNO = 2
    """The errno of the failed call follows in data[1]."""
    INVALID_DATA_SIZE = 3
    INVALID_SESSION = 4
    NO_SESSIONS_AVAILABLE = 5
    EOF = 6
    UNKNOWN_COMMAND = 7
    FILE_EXISTS = 8
    FILE_PROTECTED = 9
    FILE_NOT_FOUND = 10


@dataclass(frozen=True)
class FtpPayload:
    """One decoded FILE_TRANSFER_PROTOCOL payload."""

    seq_number: int = 0
    session: int = 0
    opcode: int = 0
    size: int = 0
    """Declared data length; may exceed ``len(data)`` in a malformed request."""
    req_opcode: int = 0
    burst_complete: int = 0
    offset: int = 0
    data: bytes = b""
    """The whole data area as received (trailing zeros of a MAVLink 2 frame restored)."""

    def encode(self) -> bytes:
        """The 251-byte payload: header, ``data`` zero-padded (truncated past 239 bytes)."""
        header = HEADER.pack(
            self.seq_number & 0xFFFF,
            self.session & 0xFF,
            self.opcode & 0xFF,
            self.size & 0xFF,
            self.req_opcode & 0xFF,
            self.burst_complete & 0xFF,
            0,
            self.offset & 0xFFFFFFFF,
        )
        return header + self.data[:MAX_DATA_LENGTH].ljust(MAX_DATA_LENGTH, b"\0")

    @property
    def valid_data(self) -> bytes:
        """data[:size]."""
        return self.data[: self.size]


def decode(payload: bytes | bytearray | list[int]) -> FtpPayload:
    """Payload bytes (any length: short ones are zero-padded, long ones cut) -> FtpPayload."""
    raw = bytes(payload)[:PAYLOAD_LENGTH].ljust(PAYLOAD_LENGTH, b"\0")
    seq, session, opcode, size, req_opcode, burst_complete, _, offset = HEADER.unpack_from(raw)
    return FtpPayload(
        seq_number=seq,
        session=session,
        opcode=opcode,
        size=size,
        req_opcode=req_opcode,
        burst_complete=burst_complete,
        offset=offset,
        data=raw[HEADER.size :],
    )


def px4_crc32(data: bytes, crc: int = 0) -> int:
    """CRC-32 as PX4's ``crc32part`` computes it, continued from ``crc``.

    The reflected 0xEDB88320 table of zlib, but seeded with 0 and without zlib's initial and
    final inversion (PX4 platforms/posix/src/px4/common/lib_crc32.c, NuttX's lib_crc32.c):
    ``zlib.crc32`` gives a different number for the same bytes.
    """
    return zlib.crc32(data, crc ^ 0xFFFFFFFF) ^ 0xFFFFFFFF
