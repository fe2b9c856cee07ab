"""MAVLink 2 signing of an endpoint, checked against pymavlink's signing on the client side."""

from __future__ import annotations

import hashlib
import logging
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mavlink_fakes import FakeVehicle, MavClient, command_long, has, make_endpoint
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import framing, messages, streams
from autopilot_emu.mavlink.endpoint import EndpointConfig
from autopilot_emu.mavlink.link_hub import LinkHub
from autopilot_emu.mavlink.signing import (
    EPOCH_2015_UNIX_S,
    IFLAG_SIGNED,
    REJECT_LOG_INTERVAL_S,
    SIGNATURE_BYTES,
    LinkSigner,
    SigningKeyError,
    SigningStreams,
    Verdict,
    key_from_passphrase,
    load_key_file,
    parse_key,
)

pytestmark = pytest.mark.sockets

KEY = bytes(range(1, 33))
OTHER_KEY = bytes(range(101, 133))
ARM = mavlink2.MAV_CMD_COMPONENT_ARM_DISARM


def _signing_client(key: bytes = KEY, link_id: int = 7, sysid: int = 245) -> MavClient:
    """A client signing as pymavlink does (mavutil's setup_signing), rejecting unsigned input."""
    client = MavClient(sysid=sysid)
    signing = client.mav.signing
    signing.secret_key = key
    signing.sign_outgoing = True
    signing.link_id = link_id
    signing.timestamp = int((time.time() - EPOCH_2015_UNIX_S) * 100_000)
    return client


@pytest.fixture
def signed_client():
    c = _signing_client()
    yield c
    c.close()


def _arm_calls(vehicle: FakeVehicle) -> int:
    return sum(call[0] == "arm" for call in vehicle.calls)


# --- keys ------------------------------------------------------------------------------------


def test_passphrase_key_is_sha256_of_the_utf8_text():
    """MAVProxy's derivation; the FIPS 180-2 test vector of "abc" pins the hash."""
    assert key_from_passphrase("abc").hex() == (
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    )
    with pytest.raises(SigningKeyError, match="empty"):
        key_from_passphrase("")


def test_key_file_holds_64_hex_characters_or_32_raw_bytes(tmp_path):
    hex_file = tmp_path / "key.hex"
    hex_file.write_text(KEY.hex().upper() + "\n")
    raw_file = tmp_path / "key.bin"
    raw_file.write_bytes(b"\n" + KEY[1:])  # raw bytes are taken as they are, whitespace too
    assert load_key_file(hex_file) == KEY
    assert load_key_file(raw_file) == b"\n" + KEY[1:]


@pytest.mark.parametrize(
    ("content", "reason"),
    [
        (b"abc", "got 3 bytes"),
        (b"zz" * 32, "got 64 bytes"),
        (KEY.hex().encode() + b"00", "got 66 bytes"),
        (b"0" * 64, "all-zero"),
        (bytes(32), "all-zero"),
    ],
)
def test_bad_key_file_is_refused_with_the_reason(tmp_path, content, reason):
    path = tmp_path / "key"
    path.write_bytes(content)
    with pytest.raises(SigningKeyError, match=reason) as info:
        load_key_file(path)
    assert str(path) in str(info.value)


def test_missing_key_file_is_a_signing_key_error(tmp_path):
    with pytest.raises(SigningKeyError, match="cannot read"):
        load_key_file(tmp_path / "nope")
    with pytest.raises(ValueError, match="32 bytes"):
        EndpointConfig(signing_key=b"short")
    assert parse_key(KEY.hex().encode()) == KEY


# --- the signer on its own -----------------------------------------------------------------


def test_outgoing_timestamps_are_monotonic_and_never_behind_the_latest_accepted():
    """Same wall-clock instant: +1 per frame; a newer accepted timestamp moves the next up."""
    now_ns = (EPOCH_2015_UNIX_S + 1000) * 10**9
    signer = LinkSigner(SigningStreams(KEY), unix_time_ns=lambda: now_ns)
    fmt = framing.fields_format(mavlink2.MAVLINK_MSG_ID_HEARTBEAT)
    values = (0, 2, 12, 0, 0, 3)

    def stamp(frame: bytes) -> int:
        return int.from_bytes(frame[-12:-6], "little")

    first = signer.encode_fields(fmt, values, 0, 1, 1)
    second = signer.encode_fields(fmt, values, 1, 1, 1)
    assert stamp(first) == 1000 * 100_000 + 1  # one past the link's start timestamp
    assert stamp(second) == stamp(first) + 1
    peer = _signing_client()
    peer.mav.signing.timestamp = stamp(second) + 50_000
    incoming = mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(peer.mav)
    peer.close()
    assert signer.check(incoming) is Verdict.SIGNED
    assert stamp(signer.encode_fields(fmt, values, 2, 1, 1)) == stamp(second) + 50_001


def test_rejections_are_logged_at_most_once_per_interval_with_a_count(caplog):
    clock = [0.0]
    signer = LinkSigner(SigningStreams(KEY), monotonic_s=lambda: clock[0])
    peer = ("10.0.0.9", 14550)  # port-literal: a ground station's address, only logged
    with caplog.at_level(logging.WARNING, logger="autopilot_emu.mavlink.signing"):
        for _ in range(5):
            signer.log_rejection(Verdict.UNSIGNED, "COMMAND_LONG", peer)
        clock[0] = REJECT_LOG_INTERVAL_S
        signer.log_rejection(Verdict.BAD_SIGNATURE, "HEARTBEAT", peer)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2
    assert f"COMMAND_LONG from {peer[0]}:{peer[1]}: unsigned" in lines[0]
    assert "bad signature (and 4 more rejected frames)" in lines[1]


# --- an endpoint with signing, over loopback UDP ---------------------------------------------


def test_signed_client_arms_reads_params_and_gets_signed_replies(signed_client):
    vehicle = FakeVehicle()
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as endpoint:
        signed_client.send(endpoint, command_long(ARM, 1))
        inbox = signed_client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
        ack = next(m for m in inbox if m.get_type() == "COMMAND_ACK")
        assert (ack.command, ack.result) == (ARM, mavlink2.MAV_RESULT_ACCEPTED)
        signed_client.send(
            endpoint, mavlink2.MAVLink_param_request_read_message(1, 1, b"MAV_SYS_ID", -1)
        )
        inbox = signed_client.exchange(endpoint, 0.01, has("PARAM_VALUE"))
        value = next(m for m in inbox if m.get_type() == "PARAM_VALUE")
        assert value.param_id == "MAV_SYS_ID"
        assert endpoint.stats.commands_handled == 1
    assert _arm_calls(vehicle) == 1
    signing = signed_client.mav.signing
    # The client's parser has the key and no unsigned callback: what it parsed is signed.
    assert signing.goodsig_count == signing.sig_count >= 2
    assert signing.badsig_count == signing.reject_count == 0
    assert ack._signed and value._signed


def test_every_hot_stream_frame_from_the_fast_path_verifies(signed_client):
    """The 13 streams packed by framing.encode_fields are signed too, and pymavlink agrees."""
    hot = sorted(messages.FIELDS)
    names = {mavlink2.mavlink_map[i].msgname for i in hot}
    rates = {name: 0.0 for name in streams.STREAMABLE} | {name: 50.0 for name in names}
    vehicle = FakeVehicle()
    with make_endpoint(
        vehicle, peers=(signed_client.address,), stream_rates_hz=rates, signing_key=KEY
    ) as endpoint:
        for ms in range(0, 201, 5):
            endpoint.poll(ms / 1000.0)
            signed_client.drain()
        assert endpoint.stats.encode_errors == 0
    received = {m.get_msgId() for m in signed_client.inbox}
    assert received >= set(hot) - {mavlink2.MAVLINK_MSG_ID_HOME_POSITION}
    assert all(m._signed for m in signed_client.inbox)
    assert all(m.get_header().incompat_flags == IFLAG_SIGNED for m in signed_client.inbox)
    signing = signed_client.mav.signing
    assert signing.goodsig_count == len(signed_client.inbox) > 13
    assert signing.badsig_count == signing.reject_count == 0


def test_unsigned_and_wrong_key_clients_are_ignored_and_counted():
    vehicle = FakeVehicle()
    unsigned = MavClient(sysid=246)
    wrong = _signing_client(OTHER_KEY, sysid=247)
    try:
        with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as ep:
            unsigned.send(ep, command_long(ARM, 1))
            wrong.send(ep, command_long(ARM, 1))
            wrong.send(ep, mavlink2.MAVLink_param_request_list_message(1, 1))
            _poll_until(ep, lambda: ep.stats.frames_bad_signature == 2)
            assert ep.stats.frames_unsigned_rejected == 1
            assert ep.stats.frames_received == 0
            assert ep.stats.commands_handled == 0
            assert ep.peers == ()  # rejected senders never become peers
            for ms in range(1, 200):
                ep.poll(ms / 1000.0)
        assert unsigned.drain() == [] and wrong.drain() == []
    finally:
        unsigned.close()
        wrong.close()
    assert _arm_calls(vehicle) == 0


def test_replayed_frame_is_rejected(signed_client):
    """The same signed frame again: its timestamp is not newer, so it is a replay."""
    vehicle = FakeVehicle()
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as endpoint:
        frame = signed_client.send(endpoint, command_long(ARM, 1))
        signed_client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
        signed_client.send_raw(endpoint, frame)
        _poll_until(endpoint, lambda: endpoint.stats.frames_replay_rejected == 1)
        assert endpoint.stats.commands_handled == 1
        assert endpoint.stats.commands_duplicate == 0  # never reached the command dispatcher
    assert _arm_calls(vehicle) == 1


def test_a_frame_captured_on_one_link_cannot_be_replayed_into_another(signed_client):
    """The vehicle's links share the accepted streams' timestamps, as PX4's instances do."""
    vehicle = FakeVehicle()
    hub = LinkHub(vehicle)
    rates = {"HEARTBEAT": 0}
    with (
        make_endpoint(vehicle, hub=hub, stream_rates_hz=rates, signing_key=KEY) as first,
        make_endpoint(vehicle, hub=hub, stream_rates_hz=rates, signing_key=KEY) as second,
    ):
        frame = signed_client.send(first, command_long(ARM, 1))
        signed_client.exchange(first, 0.0, has("COMMAND_ACK"))
        signed_client.send_raw(second, frame)
        _poll_until(second, lambda: second.stats.frames_replay_rejected == 1)
        with pytest.raises(ValueError, match="one signing key"):
            make_endpoint(vehicle, hub=hub, signing_key=OTHER_KEY)
    assert _arm_calls(vehicle) == 1


def test_tampered_frame_fails_its_signature(signed_client):
    vehicle = FakeVehicle()
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as endpoint:
        frame = bytearray(command_long(ARM, 1).pack(signed_client.mav))
        frame[-1] ^= 0xFF  # the signature's last byte (the CRC still holds)
        signed_client.send_raw(endpoint, bytes(frame))
        _poll_until(endpoint, lambda: endpoint.stats.frames_bad_signature == 1)
        # The genuine stream was not advanced by the forgery: the next genuine frame passes.
        signed_client.send(endpoint, command_long(ARM, 1))
        signed_client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
    assert _arm_calls(vehicle) == 1


def test_forged_future_timestamp_does_not_lock_out_the_genuine_client(signed_client):
    """Unlike pymavlink's check, a bad signature never moves a stream's timestamp."""
    vehicle = FakeVehicle()
    forger = _signing_client(OTHER_KEY)  # same link id and ids as signed_client
    forger.mav.signing.timestamp = signed_client.mav.signing.timestamp + 10**9
    try:
        with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as ep:
            signed_client.send(ep, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
            forger.send(ep, mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
            _poll_until(ep, lambda: ep.stats.frames_bad_signature == 1)
            signed_client.send(ep, command_long(ARM, 1))
            signed_client.exchange(ep, 0.0, has("COMMAND_ACK"))
    finally:
        forger.close()
    assert _arm_calls(vehicle) == 1


def test_unsigned_radio_status_is_accepted_as_px4_does():
    vehicle = FakeVehicle()
    radio = MavClient(sysid=51, compid=68)  # a SiK radio's ids
    try:
        with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as ep:
            radio.send(ep, mavlink2.MAVLink_radio_status_message(200, 190, 80, 20, 25, 0, 0))
            _poll_until(ep, lambda: ep.stats.frames_unsigned_accepted == 1)
            assert ep.stats.frames_received == 1
            assert ep.stats.frames_unsigned_rejected == 0
    finally:
        radio.close()


def test_mavlink1_frames_are_unsigned_and_rejected():
    vehicle = FakeVehicle()
    client = MavClient()
    try:
        with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as ep:
            frame = command_long(ARM, 1).pack(client.mav, force_mavlink1=True)
            assert frame[0] == 0xFE
            client.send_raw(ep, frame)
            _poll_until(ep, lambda: ep.stats.frames_unsigned_rejected == 1)
    finally:
        client.close()
    assert _arm_calls(vehicle) == 0


def test_endpoint_without_a_key_sends_unsigned_frames_and_accepts_signed_ones(signed_client):
    """No key: frames as before (no flag, no signature); signed input is handled unchecked."""
    vehicle = FakeVehicle()
    plain = MavClient()
    signed_client.mav.signing.allow_unsigned_callback = lambda mav, msg_id: True
    try:
        with make_endpoint(vehicle, peers=(plain.address,)) as endpoint:
            signed_client.send(endpoint, command_long(ARM, 1))
            signed_client.exchange(endpoint, 0.0, has("COMMAND_ACK"))
            plain.drain()
        frames = plain.inbox
    finally:
        plain.close()
    assert frames and all(m.get_header().incompat_flags == 0 for m in frames)
    assert all(len(m.get_msgbuf()) == m.get_header().mlen + 12 for m in frames)
    assert _arm_calls(vehicle) == 1


def test_relayed_frames_keep_their_senders_signature():
    """A GCS's command for the camera crosses to the payload link as received (PX4 resends it)."""
    vehicle = FakeVehicle()
    hub = LinkHub(vehicle)
    quiet = dict.fromkeys(streams.STREAMABLE, 0.0)
    gcs = _signing_client(sysid=255, link_id=3)
    camera = _signing_client(sysid=1, link_id=0)
    camera.mav.srcComponent = 100
    try:
        with (
            make_endpoint(vehicle, hub=hub, stream_rates_hz=quiet, signing_key=KEY) as gcs_link,
            make_endpoint(
                vehicle,
                peers=(camera.address,),
                hub=hub,
                stream_rates_hz=quiet,
                signing_key=KEY,
            ) as payload_link,
        ):
            frame = gcs.send(gcs_link, command_long(2000, target_component=100))
            _poll_until(gcs_link, lambda: gcs_link.stats.frames_forwarded == 1)
            payload_link.poll(0.0)
            _wait_for(lambda: camera.drain() or camera.inbox)
    finally:
        gcs.close()
        camera.close()
    relayed = camera.inbox[0]
    assert bytes(relayed.get_msgbuf()) == frame
    assert relayed._signed and camera.mav.signing.badsig_count == 0


def test_signature_matches_the_mavlink_definition():
    """SHA-256 over key, header, payload, CRC, link id and timestamp; first 6 bytes."""
    streams_ = SigningStreams(KEY)
    signer = LinkSigner(streams_, unix_time_ns=lambda: (EPOCH_2015_UNIX_S + 5) * 10**9)
    message = mavlink2.MAVLink_ping_message(1, 2, 0, 0)
    frame = signer.encode(message, 3, 1, 1)
    unsigned = frame[:-SIGNATURE_BYTES]
    assert unsigned[2] == IFLAG_SIGNED
    assert frame[-13] == signer.link_id == 0
    assert int.from_bytes(frame[-12:-6], "little") == 500_001
    assert frame[-6:] == hashlib.sha256(KEY + frame[:-6]).digest()[:6]


def test_mangled_signed_frames_never_raise_and_never_get_through(signed_client):
    """Any byte changed or cut in a signed command: dropped and counted, never an exception."""
    vehicle = FakeVehicle()
    template = command_long(ARM, 1)

    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}, signing_key=KEY) as endpoint:

        @settings(
            max_examples=150,
            deadline=None,
            database=None,
            derandomize=True,
            suppress_health_check=[HealthCheck.function_scoped_fixture],
        )
        @given(st.integers(0, 10_000), st.integers(1, 255), st.integers(0, 60))
        def mangle(position: int, flip: int, cut: int) -> None:
            frame = bytearray(template.pack(signed_client.mav))
            frame[position % len(frame)] ^= flip
            data = bytes(frame[: len(frame) - cut] if cut < len(frame) else frame)
            received = endpoint.stats.datagrams_received
            signed_client.send_raw(endpoint, data)
            _poll_until(endpoint, lambda: endpoint.stats.datagrams_received > received)

        mangle()
        assert endpoint.stats.commands_handled == 0
        assert endpoint.stats.handler_errors == 0
        rejected = (
            endpoint.stats.parse_errors
            + endpoint.stats.frames_bad_signature
            + endpoint.stats.frames_unsigned_rejected
            + endpoint.stats.frames_replay_rejected
            + endpoint.stats.unknown_messages
        )
        assert rejected >= endpoint.stats.datagrams_received == 150
    assert _arm_calls(vehicle) == 0


def _wait_for(condition, max_wait_s: float = 5.0) -> None:
    deadline = time.monotonic() + max_wait_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met")
        time.sleep(0.001)


def _poll_until(endpoint, condition, max_wait_s: float = 5.0) -> None:
    """Poll at t = 0 until ``condition()``; the wait only absorbs loopback delivery."""
    deadline = time.monotonic() + max_wait_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"condition not met; stats: {endpoint.stats}")
        endpoint.poll(0.0)
        time.sleep(0.001)
