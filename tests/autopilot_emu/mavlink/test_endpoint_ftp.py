"""MAVLink FTP through MavlinkEndpoint over real loopback UDP, with a pymavlink client."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest
from mavlink_fakes import has, make_endpoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.ftp import BURST_CHUNK_BYTES, BURST_PACKETS_PER_TICK
from autopilot_emu.mavlink.ftp_codec import MAX_DATA_LENGTH, ErrorCode, FtpPayload, Opcode, decode

pytestmark = pytest.mark.sockets

FTP = "FILE_TRANSFER_PROTOCOL"


@pytest.fixture
def root(tmp_path):
    r = tmp_path / "fs"
    (r / "log").mkdir(parents=True)
    (r / "hello.txt").write_bytes(b"hello")
    return r


def ftp_request(
    opcode: int,
    data: bytes = b"",
    seq: int = 0,
    offset: int = 0,
    target: tuple[int, int] = (1, 1),
) -> mavlink2.MAVLink_file_transfer_protocol_message:
    payload = FtpPayload(seq, 0, opcode, len(data), offset=offset, data=data).encode()
    return mavlink2.MAVLink_file_transfer_protocol_message(0, *target, payload)


def ftp_replies(inbox) -> list[FtpPayload]:
    return [decode(m.payload) for m in inbox if m.get_type() == FTP]


def test_list_directory_is_answered_to_the_sender(client, vehicle, root):
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        client.send(endpoint, ftp_request(Opcode.LIST_DIRECTORY, b"/\0", seq=41))
        inbox = client.exchange(endpoint, 0.0, has(FTP))
    message = next(m for m in inbox if m.get_type() == FTP)
    assert (message.get_srcSystem(), message.get_srcComponent()) == (1, 1)
    assert (message.target_system, message.target_component) == (245, 190)
    (reply,) = ftp_replies(inbox)
    assert (reply.opcode, reply.req_opcode, reply.seq_number) == (
        Opcode.ACK,
        Opcode.LIST_DIRECTORY,
        42,
    )
    assert reply.valid_data == b"S\0S\0Fhello.txt\t5\0Dlog\0"


@pytest.mark.parametrize("served", [True, False])
def test_autopilot_version_advertises_ftp_only_when_served(client, vehicle, root, served):
    """MAV_PROTOCOL_CAPABILITY_FTP, as PX4 sets it when its MAVLink instance runs FTP (-x)."""
    ftp_root = root if served else None
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=ftp_root) as endpoint:
        client.send(
            endpoint,
            mavlink2.MAVLink_command_long_message(
                1, 1, mavlink2.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 0, 1, 0, 0, 0, 0, 0, 0
            ),
        )
        inbox = client.exchange(endpoint, 0.0, has("AUTOPILOT_VERSION"))
    version = next(m for m in inbox if m.get_type() == "AUTOPILOT_VERSION")
    assert bool(version.capabilities & mavlink2.MAV_PROTOCOL_CAPABILITY_FTP) is served


@pytest.mark.parametrize("target", [(0, 0), (1, 0), (0, 1)])
def test_broadcast_targets_are_answered(client, vehicle, root, target):
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        client.send(endpoint, ftp_request(Opcode.NONE, target=target))
        inbox = client.exchange(endpoint, 0.0, has(FTP))
    assert [r.opcode for r in ftp_replies(inbox)] == [Opcode.ACK]


@pytest.mark.parametrize("target", [(2, 1), (1, 100), (2, 0)])
def test_requests_for_another_system_or_component_are_ignored(client, vehicle, root, target):
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        client.send(endpoint, ftp_request(Opcode.REMOVE_FILE, b"hello.txt\0", seq=5, target=target))
        client.send(endpoint, ftp_request(Opcode.NONE, seq=9))
        inbox = client.exchange(endpoint, 0.0, has(FTP))
    assert [(r.req_opcode, r.seq_number) for r in ftp_replies(inbox)] == [(Opcode.NONE, 10)]
    assert (root / "hello.txt").exists()


def test_without_a_root_ftp_is_not_answered(client, vehicle, root):
    """As PX4 with FTP off: no reply at all, the client times out."""
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}) as endpoint:
        client.send(endpoint, ftp_request(Opcode.REMOVE_FILE, b"/hello.txt\0"))
        client.send(endpoint, mavlink2.MAVLink_ping_message(1, 7, 0, 0))
        inbox = client.exchange(endpoint, 0.0, has("PING"))
        assert endpoint.stats.handler_errors == 0
    assert not ftp_replies(inbox)
    assert (root / "hello.txt").exists()


def test_burst_download_over_udp_is_paced_and_byte_exact(client, vehicle, root):
    data = os.urandom(BURST_CHUNK_BYTES + 5000)
    (root / "log" / "flight.ulg").write_bytes(data)
    got = bytearray()
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        client.send(endpoint, ftp_request(Opcode.OPEN_FILE_RO, b"/log/flight.ulg\0", seq=0))
        (opened,) = ftp_replies(client.exchange(endpoint, 0.0, has(FTP)))
        assert struct.unpack("<I", opened.valid_data)[0] == len(data)
        seq, now_s, done = 1, 0.0, False
        while not done:
            client.send(endpoint, ftp_request(Opcode.BURST_READ_FILE, seq=seq, offset=len(got)))
            seq += 1
            while True:
                now_s += 0.004
                replies = ftp_replies(client.exchange(endpoint, now_s, has(FTP)))
                assert len(replies) <= BURST_PACKETS_PER_TICK
                for reply in replies:
                    if reply.opcode == Opcode.ACK:
                        assert reply.offset == len(got)
                        got += reply.valid_data
                    else:
                        assert reply.valid_data == bytes([ErrorCode.EOF])
                        done = True
                if replies[-1].burst_complete:
                    break
        assert bytes(got) == data
        client.send(endpoint, ftp_request(Opcode.TERMINATE_SESSION, seq=seq))
        (terminated,) = ftp_replies(client.exchange(endpoint, now_s, has(FTP)))
        assert terminated.opcode == Opcode.ACK
        assert endpoint.stats.handler_errors == 0


def _open_fds_on(path: Path) -> list[str]:
    fds = []
    for fd in os.listdir("/proc/self/fd"):
        try:
            if os.readlink(f"/proc/self/fd/{fd}") == str(path):
                fds.append(fd)
        except OSError:
            pass
    return fds


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_closing_the_endpoint_closes_the_open_file(client, vehicle, root):
    target = (root / "hello.txt").resolve()
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        client.send(endpoint, ftp_request(Opcode.OPEN_FILE_RO, b"hello.txt\0"))
        (reply,) = ftp_replies(client.exchange(endpoint, 0.0, has(FTP)))
        assert reply.opcode == Opcode.ACK
        assert _open_fds_on(target)
    assert not _open_fds_on(target)


def test_garbage_payloads_never_reach_the_handler_error_counter(client, vehicle, root):
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, ftp_root=root) as endpoint:
        for i, junk in enumerate([b"", b"\xff" * 251, b"\x00\x00\x00\x0f\xff", os.urandom(251)]):
            message = mavlink2.MAVLink_file_transfer_protocol_message(
                0, 1, 1, junk.ljust(251, b"\0")
            )
            client.send(endpoint, message)
            client.send(endpoint, ftp_request(Opcode.NONE, seq=1000 + 2 * i))
            answered = client.exchange(endpoint, i * 0.004, has(FTP))
            while not any(r.seq_number == 1001 + 2 * i for r in ftp_replies(answered)):
                answered = client.exchange(endpoint, i * 0.004, has(FTP))
        for _ in range(20):
            endpoint.poll(1.0)
        assert endpoint.stats.handler_errors == 0


def test_a_missing_root_fails_at_construction(vehicle, tmp_path):
    with pytest.raises(ValueError, match="not a directory"):
        make_endpoint(vehicle, ftp_root=tmp_path / "nope")


def test_max_data_length_matches_the_message_field():
    """239 bytes of data after the 12-byte header fill pymavlink's 251-byte payload field."""
    field = mavlink2.MAVLink_file_transfer_protocol_message.array_lengths[-1]
    assert field == 251 == MAX_DATA_LENGTH + 12
