r"""Server side of MAVLink FTP (FILE_TRANSFER_PROTOCOL), after PX4's MavlinkFTP.

PX4 facts followed (src/modules/mavlink/mavlink_ftp.cpp):

* Requests go through one function: a declared size over 239 bytes is NAKed InvalidDataSize;
  a request whose seq_number is one below the last reply's gets that reply again (the client
  lost it); everything else runs and is answered with seq_number + 1, req_opcode = the
  request's opcode and ACK, or NAK with data[0] = ErrorCode (FailErrno adds the errno in
  data[1]; EEXIST becomes FileExists and ENOENT FileNotFound).
* Only replies of at most 4 data bytes are kept for resending (reads and listings have no side
  effects and are simply run again).
* One session: a second open is NAKed NoSessionsAvailable until TerminateSession or
  ResetSessions; a session idle for 10 s is closed. OpenFileRO answers the file size (uint32),
  CreateFile opens O_CREAT|O_TRUNC, OpenFileWO O_CREAT; ReadFile answers up to ``size`` bytes
  at ``offset`` (EOF at or past the size seen at open); WriteFile answers bytes written.
* ListDirectory packs as many entries from index ``offset`` as fit: ``F<name>\t<size>\0``,
  ``D<name>\0``, and ``S\0`` for anything else (``.``, ``..``, links, devices); EOF when asked
  past the last entry; a directory that cannot be opened is FileNotFound.
* BurstReadFile answers with a stream of ACKs of 239 bytes from ``offset``, seq_number counting
  on from the request's + 1, until EOF (a NAK EOF) or 35 000 bytes (burst_complete = 1, the
  client asks for the next burst).
* CalcFileCRC32 answers PX4's CRC-32 of the whole file (:func:`ftp_codec.px4_crc32`).

Where this server differs, and why:

* Paths are confined to the vehicle's root (:mod:`ftp_paths`); PX4 SITL lets ``..`` out.
* The session number handed out is the one the client put in its open request, not always 0.
  MAVSDK asks for 0 and sees PX4's behaviour; MAVProxy picks its own numbers and matches
  replies to operations by them (it could not download from PX4 otherwise).
* A repeated request is recognised by seq_number, opcode and session, not seq_number alone, so
  that a client that restarts its numbering per operation (MAVProxy) never gets a stale reply.
* The burst stream is paced: :data:`BURST_PACKETS_PER_TICK` per :meth:`FtpServer.tick` (one
  endpoint poll), so that a burst never floods a UDP receive buffer. Its last message (the NAK
  EOF, or the packet that ends a 35 000-byte chunk) carries burst_complete = 1.
* Checks PX4 gets wrong are done right: Write, Burst and Terminate need the open session (PX4
  accepts a missing one in places), and errnos are those of the failed call.
"""

from __future__ import annotations

import errno
import logging
import os
import stat
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.ftp_codec import (
    MAX_DATA_LENGTH,
    ErrorCode,
    FtpPayload,
    Opcode,
    decode,
    px4_crc32,
)
from autopilot_emu.mavlink.ftp_paths import FtpRoot, PathRefused, request_strings

logger = logging.getLogger(__name__)

BURST_PACKETS_PER_TICK = 8
"""Burst packets sent per tick (per endpoint poll): at 250 polls/s about 480 kB/s of
simulation time, and at most 2 kB queued at the client per poll."""
BURST_CHUNK_BYTES = 35_000
"""A burst ends (burst_complete = 1) once this much was sent (PX4: "35K chunks")."""
SESSION_IDLE_TIMEOUT_S = 10.0
"""An open session without requests is closed after this long, wall-clock s (PX4: 10 s)."""
RESEND_MAX_SIZE = 4
"""Replies with at most this many data bytes are kept for resending (PX4)."""

Send = Callable[[mavlink2.MAVLink_message], None]
Peer = tuple[int, int]


class _Nak(Exception):
    """Ends a request with a NAK."""

    def __init__(self, code: ErrorCode, err: int = 0) -> None:
        super().__init__(code.name)
        self.code = code
        self.errno = err


@dataclass
class _Session:
    """The one open file."""

    number: int
    fd: int
    size_bytes: int
    """File size when opened (ReadFile and bursts stop there), bytes."""


@dataclass
class _Burst:
    """A BurstReadFile stream in progress."""

    offset: int
    seq_number: int
    target: Peer
    sent_bytes: int = 0


@dataclass(frozen=True)
class _LastReply:
    payload: FtpPayload
    target: Peer


def _u32(value: int) -> bytes:
    return struct.pack("<I", value & 0xFFFFFFFF)


class FtpServer:
    """Answers FILE_TRANSFER_PROTOCOL requests from files under one root directory.

    Args:
        root: the directory served (must exist).
        send: sends one message to every peer.
        wall_clock_s: monotonic clock for the session idle timeout; injectable for tests.

    Raises:
        ValueError: ``root`` is not a directory.
    """

    def __init__(
        self, root: Path, send: Send, wall_clock_s: Callable[[], float] = time.monotonic
    ) -> None:
        self._root = FtpRoot(root)
        self._send = send
        self._clock = wall_clock_s
        self._session: _Session | None = None
        self._burst: _Burst | None = None
        self._last_reply: _LastReply | None = None
        self._last_request_s = 0.0
        self._work = {
            Opcode.NONE: self._none,
            Opcode.TERMINATE_SESSION: self._terminate,
            Opcode.RESET_SESSIONS: self._reset,
            Opcode.LIST_DIRECTORY: self._list,
            Opcode.OPEN_FILE_RO: lambda req: self._open(req, os.O_RDONLY),
            Opcode.READ_FILE: self._read,
            Opcode.CREATE_FILE: lambda req: self._open(req, os.O_CREAT | os.O_TRUNC | os.O_WRONLY),
            Opcode.WRITE_FILE: self._write,
            Opcode.REMOVE_FILE: self._remove_file,
            Opcode.CREATE_DIRECTORY: self._create_directory,
            Opcode.REMOVE_DIRECTORY: self._remove_directory,
            Opcode.OPEN_FILE_WO: lambda req: self._open(req, os.O_CREAT | os.O_WRONLY),
            Opcode.TRUNCATE_FILE: self._truncate,
            Opcode.RENAME: self._rename,
            Opcode.CALC_FILE_CRC32: self._crc32,
        }

    @property
    def busy(self) -> bool:
        """True while :meth:`tick` has work: a burst to stream or a session to time out."""
        return self._session is not None or self._burst is not None

    def close(self) -> None:
        """Close the open session's file, if any."""
        self._close_session()

    # --- requests ----------------------------------------------------------------------------

    def handle(self, msg: mavlink2.MAVLink_message) -> None:
        """A FILE_TRANSFER_PROTOCOL addressed to us (the link's handler checked the target)."""
        self.handle_payload(bytes(msg.payload), (msg.get_srcSystem(), msg.get_srcComponent()))

    def handle_payload(self, raw: bytes, source: Peer) -> None:
        """Answer one request payload from ``source`` (sysid, compid)."""
        self._last_request_s = self._clock()
        request = decode(raw)
        last = self._last_reply
        if (
            request.size <= MAX_DATA_LENGTH
            and last is not None
            and (request.seq_number + 1) & 0xFFFF == last.payload.seq_number
            and request.opcode == last.payload.req_opcode
            and request.session == last.payload.session
        ):
            self._transmit(last.payload, last.target)
            return
        self._last_reply = None
        try:
            data = self._run(request, source)
        except _Nak as nak:
            self._reply(request, source, Opcode.NAK, self._nak_data(nak))
            return
        if data is not None:
            self._reply(request, source, Opcode.ACK, data)

    def _run(self, request: FtpPayload, source: Peer) -> bytes | None:
        """Execute ``request``; the ACK's data, or None when the answer comes later (burst)."""
        if request.size > MAX_DATA_LENGTH:
            raise _Nak(ErrorCode.INVALID_DATA_SIZE)
        if request.opcode == Opcode.BURST_READ_FILE:
            self._start_burst(request, source)
            return None
        work = self._work.get(request.opcode)
        if work is None:
            raise _Nak(ErrorCode.UNKNOWN_COMMAND)
        try:
            return work(request)
        except PathRefused as refused:
            logger.info("FTP %s refused: %s", Opcode(request.opcode).name, refused)
            raise _Nak(refused.code) from refused
        except OSError as exc:
            raise _Nak(ErrorCode.FAIL_ERRNO, exc.errno or errno.EIO) from exc

    @staticmethod
    def _nak_data(nak: _Nak) -> bytes:
        """Data of a NAK; PX4 turns EEXIST into FileExists and ENOENT into FileNotFound."""
        code = nak.code
        if nak.errno == errno.EEXIST:
            code = ErrorCode.FILE_EXISTS
        elif nak.errno == errno.ENOENT and code == ErrorCode.FAIL_ERRNO:
            code = ErrorCode.FILE_NOT_FOUND
        if code == ErrorCode.FAIL_ERRNO:
            return bytes((code, nak.errno & 0xFF))
        return bytes((code,))

    def _reply(self, request: FtpPayload, target: Peer, opcode: Opcode, data: bytes) -> None:
        self._transmit(
            FtpPayload(
                seq_number=(request.seq_number + 1) & 0xFFFF,
                session=request.session,
                opcode=opcode,
                size=len(data),
                req_opcode=request.opcode,
                offset=request.offset,
                data=data,
            ),
            target,
        )

    def _transmit(self, payload: FtpPayload, target: Peer) -> None:
        if payload.size <= RESEND_MAX_SIZE:
            self._last_reply = _LastReply(payload, target)
        self._send(
            mavlink2.MAVLink_file_transfer_protocol_message(
                target_network=0,
                target_system=target[0],
                target_component=target[1],
                payload=payload.encode(),
            )
        )

    # --- opcodes -----------------------------------------------------------------------------

    def _path(self, request: FtpPayload, allow_root: bool = True) -> Path:
        return self._root.resolve(request_strings(request)[0], allow_root)

    def _session_of(self, request: FtpPayload) -> _Session:
        session = self._session
        if session is None or request.session != session.number:
            raise _Nak(ErrorCode.INVALID_SESSION)
        return session

    def _close_session(self) -> None:
        session, self._session, self._burst = self._session, None, None
        if session is not None:
            try:
                os.close(session.fd)
            except OSError as exc:
                logger.warning("closing FTP session file failed: %s", exc)

    @staticmethod
    def _none(request: FtpPayload) -> bytes:
        return request.valid_data

    def _terminate(self, request: FtpPayload) -> bytes:
        self._session_of(request)
        self._close_session()
        return b""

    def _reset(self, request: FtpPayload) -> bytes:
        self._close_session()
        return b""

    def _list(self, request: FtpPayload) -> bytes:
        directory = self._path(request)
        try:
            names = sorted(os.listdir(directory))
        except OSError as exc:
            raise _Nak(ErrorCode.FILE_NOT_FOUND, exc.errno or 0) from exc
        # readdir order as PX4 SITL sees it on Linux: "." and ".." first (sent as skips).
        entries = [".", "..", *names][request.offset :]
        out = bytearray()
        for name in entries:
            entry = _dir_entry(directory, name)
            if len(out) + len(entry) > MAX_DATA_LENGTH:
                break
            out += entry
        if not entries and request.offset != 0:
            raise _Nak(ErrorCode.EOF)
        return bytes(out)

    def _open(self, request: FtpPayload, flags: int) -> bytes:
        if self._session is not None:
            raise _Nak(ErrorCode.NO_SESSIONS_AVAILABLE)
        path = self._path(request)
        try:
            size = os.stat(path).st_size
        except OSError:
            size = 0
        fd = os.open(path, flags | os.O_CLOEXEC, 0o666)
        self._session = _Session(request.session, fd, size & 0xFFFFFFFF)
        return _u32(size)

    def _read(self, request: FtpPayload) -> bytes:
        session = self._session_of(request)
        if request.offset >= session.size_bytes:
            raise _Nak(ErrorCode.EOF)
        return os.pread(session.fd, request.size, request.offset)

    def _write(self, request: FtpPayload) -> bytes:
        session = self._session_of(request)
        return _u32(os.pwrite(session.fd, request.valid_data, request.offset))

    def _remove_file(self, request: FtpPayload) -> bytes:
        os.unlink(self._path(request, allow_root=False))
        return b""

    def _create_directory(self, request: FtpPayload) -> bytes:
        os.mkdir(self._path(request), 0o777)
        return b""

    def _remove_directory(self, request: FtpPayload) -> bytes:
        os.rmdir(self._path(request, allow_root=False))
        return b""

    def _truncate(self, request: FtpPayload) -> bytes:
        os.truncate(self._path(request, allow_root=False), request.offset)
        return b""

    def _rename(self, request: FtpPayload) -> bytes:
        strings = request_strings(request)
        if len(strings) < 2:  # no second path
            raise _Nak(ErrorCode.FAIL_ERRNO, errno.EINVAL)
        old = self._root.resolve(strings[0], allow_root=False)
        new = self._root.resolve(strings[1], allow_root=False)
        os.rename(old, new)
        return b""

    def _crc32(self, request: FtpPayload) -> bytes:
        crc = 0
        with open(self._path(request), "rb") as file:
            while chunk := file.read(65536):
                crc = px4_crc32(chunk, crc)
        return _u32(crc)

    # --- burst -------------------------------------------------------------------------------

    def _start_burst(self, request: FtpPayload, source: Peer) -> None:
        self._session_of(request)
        self._burst = _Burst(request.offset, (request.seq_number + 1) & 0xFFFF, source)

    def tick(self) -> None:
        """Send the next packets of a burst; close a session idle too long."""
        if self._burst is not None:
            self._last_request_s = self._clock()
            for _ in range(BURST_PACKETS_PER_TICK):
                if not self._send_burst_packet():
                    break
        elif (
            self._session is not None
            and self._clock() - self._last_request_s > SESSION_IDLE_TIMEOUT_S
        ):
            logger.warning(
                "FTP session closed after %.0f s without activity", SESSION_IDLE_TIMEOUT_S
            )
            self._close_session()
            self._last_reply = None

    def _send_burst_packet(self) -> bool:
        """Send one packet of the burst; False once the burst is over."""
        burst, session = self._burst, self._session
        if burst is None or session is None:
            return False
        header = FtpPayload(
            seq_number=burst.seq_number,
            session=session.number,
            req_opcode=Opcode.BURST_READ_FILE,
            offset=burst.offset,
        )
        burst.seq_number = (burst.seq_number + 1) & 0xFFFF
        data = b""
        nak = _Nak(ErrorCode.EOF)
        if burst.offset < session.size_bytes:
            try:
                data = os.pread(session.fd, MAX_DATA_LENGTH, burst.offset)
            except OSError as exc:
                nak = _Nak(ErrorCode.FAIL_ERRNO, exc.errno or errno.EIO)
        if not data:
            self._burst = None
            nak_data = self._nak_data(nak)
            self._transmit(
                replace(
                    header, opcode=Opcode.NAK, size=len(nak_data), data=nak_data, burst_complete=1
                ),
                burst.target,
            )
            return False
        burst.offset += len(data)
        burst.sent_bytes += len(data)
        done = burst.sent_bytes > BURST_CHUNK_BYTES
        if done:
            self._burst = None
        self._transmit(
            replace(header, opcode=Opcode.ACK, size=len(data), data=data, burst_complete=int(done)),
            burst.target,
        )
        return not done


def _dir_entry(directory: Path, name: str) -> bytes:
    r"""One ListDirectory entry: F<name>\t<size>, D<name> or S (not a file nor a directory)."""
    skip = b"S\0"
    if name in (".", ".."):
        return skip
    try:
        mode = os.lstat(directory / name)
    except OSError:
        return skip
    encoded = os.fsencode(name)
    if stat.S_ISREG(mode.st_mode):
        entry = b"F" + encoded + b"\t" + str(mode.st_size & 0xFFFFFFFF).encode() + b"\0"
    elif stat.S_ISDIR(mode.st_mode):
        entry = b"D" + encoded + b"\0"
    else:
        return skip
    # A name too long to ever fit in a reply is skipped (PX4 would stall the listing on it).
    return entry if len(entry) <= MAX_DATA_LENGTH else skip
