"""FtpServer with payload bytes in and out: every opcode, every NAK, the root's walls, bursts."""

from __future__ import annotations

import errno
import os
import struct
import tempfile
import zlib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from autopilot_emu.mavlink.ftp import (
    BURST_CHUNK_BYTES,
    BURST_PACKETS_PER_TICK,
    SESSION_IDLE_TIMEOUT_S,
    FtpServer,
)
from autopilot_emu.mavlink.ftp_codec import (
    MAX_DATA_LENGTH,
    PAYLOAD_LENGTH,
    ErrorCode,
    FtpPayload,
    Opcode,
    decode,
    px4_crc32,
)

CLIENT = (245, 190)


class Clock:
    """A settable wall clock."""

    def __init__(self) -> None:
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


class Harness:
    """An FtpServer over ``root`` whose sent messages are collected."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.sent: list = []
        self.clock = Clock()
        self.server = FtpServer(root, self.sent.append, self.clock)
        self.seq = 0

    def raw(self, payload: bytes, source=CLIENT) -> list[FtpPayload]:
        """Send raw payload bytes; the decoded replies sent in answer."""
        self.sent.clear()
        self.server.handle_payload(payload, source)
        return [decode(m.payload) for m in self.sent]

    def ask(
        self,
        opcode: int,
        data: bytes = b"",
        offset: int = 0,
        session: int = 0,
        size: int | None = None,
        seq: int | None = None,
    ) -> FtpPayload:
        """One request with the next sequence number; its single reply."""
        if seq is None:
            seq = self.seq
            self.seq += 1
        request = FtpPayload(
            seq_number=seq,
            session=session,
            opcode=opcode,
            size=len(data) if size is None else size,
            offset=offset,
            data=data,
        )
        replies = self.raw(request.encode())
        assert len(replies) == 1, replies
        reply = replies[0]
        assert reply.seq_number == (seq + 1) & 0xFFFF
        assert reply.req_opcode == opcode
        return reply

    def tick(self) -> list[FtpPayload]:
        self.sent.clear()
        self.server.tick()
        return [decode(m.payload) for m in self.sent]


def path(text: str) -> bytes:
    """A path as MAVSDK sends it: the string and its NUL."""
    return text.encode() + b"\0"


def acked(reply: FtpPayload) -> bytes:
    assert reply.opcode == Opcode.ACK, f"NAK {nak_code(reply)!r}"
    return reply.valid_data


def nak_code(reply: FtpPayload) -> ErrorCode | tuple[ErrorCode, int]:
    """The NAK's ErrorCode; (FAIL_ERRNO, errno) for FailErrno."""
    assert reply.opcode == Opcode.NAK
    code = ErrorCode(reply.data[0])
    if code == ErrorCode.FAIL_ERRNO:
        assert reply.size == 2
        return (code, reply.data[1])
    assert reply.size == 1
    return code


def u32(data: bytes) -> int:
    return struct.unpack("<I", data)[0]


def crc32_reference(data: bytes) -> int:
    """Bit by bit: reflected polynomial 0xEDB88320, register starts at 0, no final XOR."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
    return crc


def listing(h: Harness, directory: str) -> list[bytes]:
    """Every entry of ``directory``, page by page until the EOF NAK, as a client would."""
    entries: list[bytes] = []
    while True:
        reply = h.ask(Opcode.LIST_DIRECTORY, path(directory), offset=len(entries))
        if reply.opcode == Opcode.NAK:
            assert nak_code(reply) == ErrorCode.EOF
            return entries
        page = acked(reply)
        assert page.endswith(b"\0")
        entries += page[:-1].split(b"\0")


@pytest.fixture
def root(tmp_path):
    r = tmp_path / "fs"
    (r / "log").mkdir(parents=True)
    (r / "hello.txt").write_bytes(b"hello")
    return r


@pytest.fixture
def h(root):
    harness = Harness(root)
    yield harness
    harness.server.close()


# --- the payload ----------------------------------------------------------------------------


def test_payload_layout_is_px4s_packed_header():
    """seq (LE u16), session, opcode, size, req_opcode, burst_complete, pad, offset (LE u32)."""
    raw = FtpPayload(0x1234, 5, 6, 3, 7, 1, 0xA0B0C0D0, b"xyz").encode()
    assert len(raw) == PAYLOAD_LENGTH == 251
    assert raw[:12] == bytes([0x34, 0x12, 5, 6, 3, 7, 1, 0, 0xD0, 0xC0, 0xB0, 0xA0])
    assert raw[12:15] == b"xyz"
    assert set(raw[15:]) == {0}
    assert decode(raw) == FtpPayload(0x1234, 5, 6, 3, 7, 1, 0xA0B0C0D0, b"xyz".ljust(239, b"\0"))


def test_short_payloads_decode_as_zero_padded():
    """A MAVLink 2 frame drops trailing zeros: a short payload reads as if padded."""
    assert decode(b"\x01") == FtpPayload(seq_number=1, data=bytes(MAX_DATA_LENGTH))


def test_crc32_is_px4s_not_zlibs():
    data = os.urandom(5000)
    assert px4_crc32(data) == crc32_reference(data)
    assert px4_crc32(data[3000:], px4_crc32(data[:3000])) == crc32_reference(data)
    assert px4_crc32(b"123456789") != zlib.crc32(b"123456789")


# --- opcodes ---------------------------------------------------------------------------------


def test_none_is_acked(h):
    assert h.ask(Opcode.NONE).opcode == Opcode.ACK


def test_list_root_with_file_sizes_dirs_and_skip_entries(h, root):
    (root / "link").symlink_to(root / "hello.txt")
    os.mkfifo(root / "fifo")
    entries = listing(h, "/")
    assert entries[:2] == [b"S", b"S"]  # "." and ".."
    assert sorted(entries[2:]) == sorted([b"Fhello.txt\t5", b"Dlog", b"S", b"S"])


def test_list_pages_through_a_big_directory(h, root):
    names = {f"file_{i:03d}_with_a_longish_name.bin" for i in range(60)}
    for name in names:
        (root / "log" / name).write_bytes(b"x" * 7)
    first = acked(h.ask(Opcode.LIST_DIRECTORY, path("log")))
    assert len(first) <= MAX_DATA_LENGTH
    entries = listing(h, "/log")
    assert len(entries) == len(names) + 2
    assert {e.decode() for e in entries[2:]} == {f"F{n}\t7" for n in names}


def test_list_leading_slash_and_none_mean_the_same(h):
    assert (
        h.ask(Opcode.LIST_DIRECTORY, path("/log")).data
        == h.ask(Opcode.LIST_DIRECTORY, path("log")).data
    )
    assert acked(h.ask(Opcode.LIST_DIRECTORY, b"")) == acked(h.ask(Opcode.LIST_DIRECTORY, b"/"))


def test_read_a_file_with_open_read_terminate(h, root):
    data = os.urandom(1000)
    (root / "log" / "data.bin").write_bytes(data)
    reply = h.ask(Opcode.OPEN_FILE_RO, path("/log/data.bin"), session=0)
    assert u32(acked(reply)) == 1000
    got = b""
    while True:
        reply = h.ask(Opcode.READ_FILE, offset=len(got), size=MAX_DATA_LENGTH)
        if reply.opcode == Opcode.NAK:
            assert nak_code(reply) == ErrorCode.EOF
            break
        assert reply.offset == len(got)
        got += acked(reply)
    assert got == data
    assert acked(h.ask(Opcode.TERMINATE_SESSION)) == b""
    assert nak_code(h.ask(Opcode.READ_FILE, size=10)) == ErrorCode.INVALID_SESSION


def test_read_returns_the_requested_size(h):
    h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"))
    assert acked(h.ask(Opcode.READ_FILE, offset=1, size=3)) == b"ell"


def test_session_number_is_the_one_asked_for(h):
    """PX4 always hands out 0; we echo the client's number (0 for MAVSDK and QGC)."""
    reply = h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"), session=37)
    assert reply.session == 37
    assert nak_code(h.ask(Opcode.READ_FILE, session=0, size=5)) == ErrorCode.INVALID_SESSION
    assert acked(h.ask(Opcode.READ_FILE, session=37, size=5)) == b"hello"
    assert nak_code(h.ask(Opcode.TERMINATE_SESSION, session=1)) == ErrorCode.INVALID_SESSION
    assert h.ask(Opcode.TERMINATE_SESSION, session=37).opcode == Opcode.ACK


def test_create_write_and_read_back(h, root):
    (root / "log" / "new.bin").write_bytes(b"old content that gets truncated")
    acked(h.ask(Opcode.CREATE_FILE, path("/log/new.bin")))
    chunks = [os.urandom(MAX_DATA_LENGTH), os.urandom(100)]
    reply = h.ask(Opcode.WRITE_FILE, chunks[0], offset=0)
    assert u32(acked(reply)) == MAX_DATA_LENGTH
    assert u32(acked(h.ask(Opcode.WRITE_FILE, chunks[1], offset=MAX_DATA_LENGTH))) == 100
    acked(h.ask(Opcode.TERMINATE_SESSION))
    assert (root / "log" / "new.bin").read_bytes() == b"".join(chunks)


def test_open_write_only_keeps_the_content(h, root):
    acked(h.ask(Opcode.OPEN_FILE_WO, path("hello.txt")))
    acked(h.ask(Opcode.WRITE_FILE, b"J", offset=0))
    acked(h.ask(Opcode.TERMINATE_SESSION))
    assert (root / "hello.txt").read_bytes() == b"Jello"
    acked(h.ask(Opcode.OPEN_FILE_WO, path("brand_new")))
    acked(h.ask(Opcode.RESET_SESSIONS))
    assert (root / "brand_new").read_bytes() == b""


def test_remove_file(h, root):
    acked(h.ask(Opcode.REMOVE_FILE, path("/hello.txt")))
    assert not (root / "hello.txt").exists()
    assert nak_code(h.ask(Opcode.REMOVE_FILE, path("/hello.txt"))) == ErrorCode.FILE_NOT_FOUND
    assert nak_code(h.ask(Opcode.REMOVE_FILE, path("/log"))) == (
        ErrorCode.FAIL_ERRNO,
        errno.EISDIR,
    )


def test_create_and_remove_directory(h, root):
    acked(h.ask(Opcode.CREATE_DIRECTORY, path("/log/flight1")))
    assert (root / "log" / "flight1").is_dir()
    assert nak_code(h.ask(Opcode.CREATE_DIRECTORY, path("/log/flight1"))) == ErrorCode.FILE_EXISTS
    assert nak_code(h.ask(Opcode.CREATE_DIRECTORY, path("/a/b"))) == ErrorCode.FILE_NOT_FOUND
    (root / "log" / "flight1" / "x").write_bytes(b"")
    assert nak_code(h.ask(Opcode.REMOVE_DIRECTORY, path("/log/flight1"))) == (
        ErrorCode.FAIL_ERRNO,
        errno.ENOTEMPTY,
    )
    (root / "log" / "flight1" / "x").unlink()
    acked(h.ask(Opcode.REMOVE_DIRECTORY, path("/log/flight1")))
    assert not (root / "log" / "flight1").exists()


def test_truncate_file_to_offset(h, root):
    acked(h.ask(Opcode.TRUNCATE_FILE, path("hello.txt"), offset=2))
    assert (root / "hello.txt").read_bytes() == b"he"
    acked(h.ask(Opcode.TRUNCATE_FILE, path("hello.txt"), offset=4))
    assert (root / "hello.txt").read_bytes() == b"he\0\0"
    assert nak_code(h.ask(Opcode.TRUNCATE_FILE, path("nope"), offset=0)) == (
        ErrorCode.FILE_NOT_FOUND
    )


def test_rename(h, root):
    acked(h.ask(Opcode.RENAME, b"hello.txt\0/log/moved.txt\0"))
    assert (root / "log" / "moved.txt").read_bytes() == b"hello"
    # MAVProxy sends "old\0new" without the final NUL.
    acked(h.ask(Opcode.RENAME, b"/log/moved.txt\0/back.txt"))
    assert (root / "back.txt").read_bytes() == b"hello"
    assert nak_code(h.ask(Opcode.RENAME, b"back.txt")) == (ErrorCode.FAIL_ERRNO, errno.EINVAL)
    assert nak_code(h.ask(Opcode.RENAME, b"nope\0x")) == ErrorCode.FILE_NOT_FOUND


def test_crc32_of_a_file(h, root):
    data = os.urandom(70_000)
    (root / "log" / "big.bin").write_bytes(data)
    reply = h.ask(Opcode.CALC_FILE_CRC32, path("/log/big.bin"))
    assert u32(acked(reply)) == crc32_reference(data)
    assert nak_code(h.ask(Opcode.CALC_FILE_CRC32, path("/nope"))) == ErrorCode.FILE_NOT_FOUND


def burst_download(h: Harness, name: str, session: int = 0) -> tuple[bytes, list[FtpPayload]]:
    """Open, then burst (asking again after each burst_complete) until the EOF NAK."""
    size = u32(acked(h.ask(Opcode.OPEN_FILE_RO, path(name), session=session)))
    got = bytearray()
    packets: list[FtpPayload] = []
    while True:
        seq = h.seq
        h.seq += 1
        request = FtpPayload(seq, session, Opcode.BURST_READ_FILE, MAX_DATA_LENGTH, offset=len(got))
        assert h.raw(request.encode()) == []  # the answer is the stream that follows
        expected_seq = seq + 1
        last = None
        while last is None or not last.burst_complete:
            sent = h.tick()
            assert 1 <= len(sent) <= BURST_PACKETS_PER_TICK
            for packet in sent:
                assert packet.seq_number == expected_seq
                assert packet.req_opcode == Opcode.BURST_READ_FILE
                assert packet.session == session
                expected_seq += 1
                if packet.opcode == Opcode.ACK:
                    assert packet.offset == len(got)
                    got += packet.valid_data
            packets += sent
            last = sent[-1]
        if last.opcode == Opcode.NAK:
            assert nak_code(last) == ErrorCode.EOF
            assert len(got) == size
            return bytes(got), packets
        assert h.tick() == []  # the burst is over until the client asks again


def test_burst_read_of_a_multi_kilobyte_file_is_byte_exact(h, root):
    data = os.urandom(2 * BURST_CHUNK_BYTES + 1234)
    (root / "log" / "big.bin").write_bytes(data)
    got, packets = burst_download(h, "/log/big.bin")
    assert got == data
    acks = [p for p in packets if p.opcode == Opcode.ACK]
    assert all(p.size == MAX_DATA_LENGTH for p in acks[:-1])
    completes = [p for p in packets if p.burst_complete]
    assert len(completes) == 3  # two full chunks, then the EOF NAK
    acked(h.ask(Opcode.TERMINATE_SESSION))


def test_burst_needs_the_open_session(h):
    reply = h.ask(Opcode.BURST_READ_FILE, size=MAX_DATA_LENGTH)
    assert nak_code(reply) == ErrorCode.INVALID_SESSION
    assert not h.server.busy


def test_terminate_stops_a_burst(h, root):
    (root / "big.bin").write_bytes(os.urandom(10_000))
    h.ask(Opcode.OPEN_FILE_RO, path("big.bin"))
    h.raw(FtpPayload(50, 0, Opcode.BURST_READ_FILE, MAX_DATA_LENGTH).encode())
    assert len(h.tick()) == BURST_PACKETS_PER_TICK
    acked(h.ask(Opcode.TERMINATE_SESSION))
    assert h.tick() == []
    assert not h.server.busy


# --- NAKs ------------------------------------------------------------------------------------


def test_declared_size_past_the_data_area_is_invalid(h):
    reply = h.ask(Opcode.LIST_DIRECTORY, b"/", size=MAX_DATA_LENGTH + 1)
    assert nak_code(reply) == ErrorCode.INVALID_DATA_SIZE


@pytest.mark.parametrize("opcode", [16, 42, 127, Opcode.ACK, Opcode.NAK, 255])
def test_unknown_opcodes(h, opcode):
    assert nak_code(h.ask(opcode)) == ErrorCode.UNKNOWN_COMMAND


@pytest.mark.parametrize("opcode", [Opcode.READ_FILE, Opcode.WRITE_FILE, Opcode.TERMINATE_SESSION])
def test_session_commands_without_a_session(h, opcode):
    assert nak_code(h.ask(opcode, b"x")) == ErrorCode.INVALID_SESSION


def test_sessions_run_out_after_one(h):
    """PX4 has one session: a second open waits for Terminate or Reset."""
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))
    for opcode in (Opcode.OPEN_FILE_RO, Opcode.CREATE_FILE, Opcode.OPEN_FILE_WO):
        reply = h.ask(opcode, path("hello.txt"))
        assert nak_code(reply) == ErrorCode.NO_SESSIONS_AVAILABLE
    acked(h.ask(Opcode.RESET_SESSIONS))
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))


def test_idle_session_is_closed_after_the_timeout(h):
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))
    h.clock.now_s += SESSION_IDLE_TIMEOUT_S * 0.9
    h.tick()
    assert nak_code(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"))) == (
        ErrorCode.NO_SESSIONS_AVAILABLE
    )
    h.clock.now_s += SESSION_IDLE_TIMEOUT_S * 1.1
    h.tick()
    assert not h.server.busy
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))


def test_eof(h):
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))
    assert nak_code(h.ask(Opcode.READ_FILE, offset=5, size=10)) == ErrorCode.EOF
    assert nak_code(h.ask(Opcode.LIST_DIRECTORY, path("/"), offset=4)) == ErrorCode.EOF


def test_missing_things_are_not_found(h):
    assert nak_code(h.ask(Opcode.OPEN_FILE_RO, path("/nope"))) == ErrorCode.FILE_NOT_FOUND
    assert nak_code(h.ask(Opcode.LIST_DIRECTORY, path("/nope"))) == ErrorCode.FILE_NOT_FOUND
    assert nak_code(h.ask(Opcode.LIST_DIRECTORY, path("/hello.txt"))) == ErrorCode.FILE_NOT_FOUND


def test_read_of_a_write_only_session_fails_with_errno(h):
    acked(h.ask(Opcode.OPEN_FILE_WO, path("hello.txt")))
    assert nak_code(h.ask(Opcode.READ_FILE, size=1)) == (ErrorCode.FAIL_ERRNO, errno.EBADF)


@pytest.mark.parametrize("name", ["@PARAM/param.pck", "/@PARAM/param.pck", "@MISSION/mission.dat"])
def test_ardupilot_virtual_files_are_not_found(h, root, name):
    (root / "@PARAM").mkdir()
    (root / "@PARAM" / "param.pck").write_bytes(b"real file, still refused")
    for opcode in (Opcode.OPEN_FILE_RO, Opcode.CALC_FILE_CRC32, Opcode.REMOVE_FILE):
        assert nak_code(h.ask(opcode, path(name))) == ErrorCode.FILE_NOT_FOUND


# --- the root's walls ------------------------------------------------------------------------

ESCAPES = ["..", "../outside.txt", "/../outside.txt", "log/../../outside.txt", "a/../../../x"]


@pytest.fixture
def outside(root):
    sentinel = root.parent / "outside.txt"
    sentinel.write_bytes(b"not yours")
    return sentinel


@pytest.mark.parametrize("name", ESCAPES)
@pytest.mark.parametrize(
    "opcode",
    [
        Opcode.LIST_DIRECTORY,
        Opcode.OPEN_FILE_RO,
        Opcode.CREATE_FILE,
        Opcode.OPEN_FILE_WO,
        Opcode.REMOVE_FILE,
        Opcode.CREATE_DIRECTORY,
        Opcode.REMOVE_DIRECTORY,
        Opcode.TRUNCATE_FILE,
        Opcode.CALC_FILE_CRC32,
    ],
)
def test_dot_dot_escapes_are_protected(h, outside, name, opcode):
    assert nak_code(h.ask(opcode, path(name))) == ErrorCode.FILE_PROTECTED
    assert outside.read_bytes() == b"not yours"
    assert not h.server.busy


def test_absolute_paths_stay_inside_the_root(h, root):
    assert nak_code(h.ask(Opcode.OPEN_FILE_RO, path("/etc/passwd"))) == ErrorCode.FILE_NOT_FOUND
    acked(h.ask(Opcode.CREATE_DIRECTORY, path("/etc")))
    assert (root / "etc").is_dir()


def test_symlinks_out_of_the_root_are_protected(h, root, outside):
    (root / "log" / "evil.txt").symlink_to(outside)
    (root / "evil_dir").symlink_to(root.parent)
    for opcode, name in [
        (Opcode.OPEN_FILE_RO, "/log/evil.txt"),
        (Opcode.OPEN_FILE_WO, "/log/evil.txt"),
        (Opcode.CREATE_FILE, "/log/evil.txt"),
        (Opcode.TRUNCATE_FILE, "/log/evil.txt"),
        (Opcode.CALC_FILE_CRC32, "/log/evil.txt"),
        (Opcode.REMOVE_FILE, "/log/evil.txt"),
        (Opcode.LIST_DIRECTORY, "/evil_dir"),
        (Opcode.OPEN_FILE_RO, "/evil_dir/outside.txt"),
        (Opcode.REMOVE_FILE, "/evil_dir/outside.txt"),
        (Opcode.CREATE_FILE, "/evil_dir/new.txt"),
        (Opcode.CREATE_DIRECTORY, "/evil_dir/newdir"),
    ]:
        assert nak_code(h.ask(opcode, path(name))) == ErrorCode.FILE_PROTECTED, (opcode, name)
    assert outside.read_bytes() == b"not yours"
    assert sorted(p.name for p in root.parent.iterdir()) == ["fs", "outside.txt"]


def test_symlinks_inside_the_root_are_followed(h, root):
    (root / "log" / "alias.txt").symlink_to(root / "hello.txt")
    acked(h.ask(Opcode.OPEN_FILE_RO, path("/log/alias.txt")))
    assert acked(h.ask(Opcode.READ_FILE, size=5)) == b"hello"


def test_rename_cannot_move_things_in_or_out(h, root, outside):
    assert nak_code(h.ask(Opcode.RENAME, b"hello.txt\0../stolen.txt")) == ErrorCode.FILE_PROTECTED
    assert nak_code(h.ask(Opcode.RENAME, b"../outside.txt\0got.txt")) == ErrorCode.FILE_PROTECTED
    assert (root / "hello.txt").exists()
    assert outside.read_bytes() == b"not yours"


def test_the_root_itself_cannot_be_removed_or_moved(h, root):
    for opcode, data in [
        (Opcode.REMOVE_DIRECTORY, path("/")),
        (Opcode.REMOVE_DIRECTORY, path("log/..")),
        (Opcode.REMOVE_FILE, path("")),
        (Opcode.RENAME, b"/\0elsewhere"),
        (Opcode.RENAME, b"log\0/"),
    ]:
        assert nak_code(h.ask(opcode, data)) == ErrorCode.FILE_PROTECTED
    assert root.is_dir() and (root / "log").is_dir()


# --- retransmissions -------------------------------------------------------------------------


def test_a_repeated_request_gets_the_same_reply_without_running_again(h):
    first = h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"), seq=10)
    again = h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"), seq=10)
    assert again == first  # not NoSessionsAvailable: the open did not run twice
    assert u32(acked(again)) == 5
    fresh = h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"), seq=11)
    assert nak_code(fresh) == ErrorCode.NO_SESSIONS_AVAILABLE


def test_a_repeated_nak_is_resent(h, root):
    first = h.ask(Opcode.CREATE_DIRECTORY, path("log"), seq=3)
    assert nak_code(first) == ErrorCode.FILE_EXISTS
    (root / "log").rmdir()
    assert h.ask(Opcode.CREATE_DIRECTORY, path("log"), seq=3) == first
    assert not (root / "log").exists()


def test_same_seq_with_another_opcode_or_session_is_a_new_request(h, root):
    """PX4 compares seq alone; MAVProxy restarts seq at 0 for every operation."""
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt"), seq=0, session=9))
    acked(h.ask(Opcode.TERMINATE_SESSION, seq=0, session=9))
    (root / "other.bin").write_bytes(b"abc")
    reply = h.ask(Opcode.OPEN_FILE_RO, path("other.bin"), seq=0, session=10)
    assert reply.session == 10 and u32(acked(reply)) == 3


def test_large_replies_are_run_again(h, root):
    acked(h.ask(Opcode.OPEN_FILE_RO, path("hello.txt")))
    first = h.ask(Opcode.READ_FILE, size=5, seq=20)
    (root / "hello.txt").write_bytes(b"HELLO")
    assert acked(h.ask(Opcode.READ_FILE, size=5, seq=20)) == b"HELLO" != acked(first)


# --- garbage ---------------------------------------------------------------------------------

_PATHS = st.sampled_from(
    [
        b"",
        b"/",
        b"log",
        b"/log/",
        b"..",
        b"../x",
        b"hello.txt",
        b"@PARAM/p",
        b"\xff\xfe",
        b"a" * 300,
    ]
)


@st.composite
def requests(draw) -> bytes:
    """Structured requests with random fields, or plain random bytes."""
    if draw(st.booleans()):
        return draw(st.binary(max_size=PAYLOAD_LENGTH + 10))
    data = draw(st.one_of(_PATHS, st.binary(max_size=MAX_DATA_LENGTH)))
    return FtpPayload(
        seq_number=draw(st.integers(0, 0xFFFF)),
        session=draw(st.integers(0, 3)),
        opcode=draw(st.integers(0, 20) | st.integers(0, 255)),
        size=draw(st.integers(0, 255)),
        offset=draw(st.integers(0, 3) | st.integers(0, 0xFFFFFFFF)),
        data=data,
    ).encode()


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(st.lists(requests(), min_size=1, max_size=12))
def test_garbage_never_raises_and_never_leaves_the_root(batch):
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fs"
        (root / "log").mkdir(parents=True)
        (root / "hello.txt").write_bytes(b"hello")
        sentinel = Path(tmp) / "x"
        sentinel.write_bytes(b"keep")
        h = Harness(root)
        try:
            for raw in batch:
                for reply in h.raw(raw):
                    assert reply.opcode in (Opcode.ACK, Opcode.NAK)
                for _ in range(3):
                    h.tick()
            assert h.ask(Opcode.NONE, seq=60000).opcode == Opcode.ACK
        finally:
            h.server.close()
        assert sentinel.read_bytes() == b"keep"
        assert sorted(p.name for p in Path(tmp).iterdir()) == ["fs", "x"]


def test_a_root_that_is_not_a_directory_is_refused(tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        FtpServer(tmp_path / "missing", lambda m: None)
