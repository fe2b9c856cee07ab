"""Hot streams packed from field values: byte for byte pymavlink's frames of the same message."""

from __future__ import annotations

import struct

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from mavlink_fakes import INT_RANGES, FakeVehicle, MavClient, make_endpoint, make_snapshot
from pymavlink.dialects.v10 import common as mavlink1
from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.generator import mavcrc

from autopilot_emu.mavlink import framing, messages, streams
from autopilot_emu.params import ParamStore

pytestmark = pytest.mark.sockets

CONTEXT = messages.MessageContext(sysid=7, params=ParamStore(), epoch_start_us=0)
HOT = sorted(messages.FIELDS)


def _value(type_name: str) -> st.SearchStrategy:
    """Any value of a MAVLink wire type, zero often (the payload truncation's case)."""
    if type_name == "float":
        return st.just(0.0) | st.floats(width=32)
    low, high = INT_RANGES[type_name]
    return st.just(0) | st.sampled_from((low, high)) | st.integers(low, high)


def _wire_values(msg_id: int) -> st.SearchStrategy[tuple]:
    """Flat wire-order values of message ``msg_id`` (arrays element by element)."""
    cls = mavlink2.mavlink_map[msg_id]
    types = dict(zip(cls.fieldnames, cls.fieldtypes, strict=True))
    parts = [
        _value(types[name])
        for name, length in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True)
        for _ in range(max(1, length))
    ]
    return st.tuples(*parts)


def _pymavlink_object(msg_id: int, values: tuple) -> mavlink2.MAVLink_message:
    """pymavlink's message object holding flat wire-order ``values``."""
    cls = mavlink2.mavlink_map[msg_id]
    kwargs, k = {}, 0
    for name, length in zip(cls.ordered_fieldnames, cls.array_lengths, strict=True):
        if length:
            kwargs[name], k = list(values[k : k + length]), k + length
        else:
            kwargs[name], k = values[k], k + 1
    return cls(**kwargs)


def _pymavlink_frame(message: mavlink2.MAVLink_message, seq: int, sysid: int, compid: int):
    mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    mav.seq = seq
    return message.pack(mav)


@st.composite
def _hot_message(draw: st.DrawFn) -> tuple[int, tuple]:
    msg_id = draw(st.sampled_from(HOT))
    return msg_id, draw(_wire_values(msg_id))


@settings(max_examples=600, deadline=None)
@given(
    message=_hot_message(),
    seq=st.integers(0, 255),
    sysid=st.integers(1, 255),
    compid=st.integers(1, 255),
)
def test_fields_frame_is_pymavlinks_frame(message, seq, sysid, compid):
    msg_id, values = message
    frame = framing.encode_fields(framing.fields_format(msg_id), values, seq, sysid, compid)
    assert frame == _pymavlink_frame(_pymavlink_object(msg_id, values), seq, sysid, compid)


@pytest.mark.parametrize("msg_id", HOT, ids=lambda i: mavlink2.mavlink_map[i].msgname)
@given(data=st.data())
@settings(max_examples=40, deadline=None)
@example(data=None)  # all fields zero: the payload shrinks to a single zero byte
def test_trailing_zeros_are_cut_as_pymavlink_cuts_them(msg_id, data):
    fmt = framing.fields_format(msg_id)
    if data is None:
        values = (0,) * fmt.field_count
    else:
        # A non-zero head followed by zeros: the frame ends where the non-zero bytes end.
        values = list(data.draw(_wire_values(msg_id)))
        keep = data.draw(st.integers(0, len(values)))
        values = tuple(values[:keep]) + (0,) * (len(values) - keep)
    frame = framing.encode_fields(fmt, values, 9, 1, 1)
    assert frame == _pymavlink_frame(_pymavlink_object(msg_id, values), 9, 1, 1)
    payload_len = frame[1]
    full = fmt.payload.size
    assert 1 <= payload_len <= full
    assert payload_len == max(1, len(fmt.payload.pack(*values).rstrip(b"\x00")))


@pytest.mark.parametrize("msg_id", HOT, ids=lambda i: mavlink2.mavlink_map[i].msgname)
def test_fields_of_a_snapshot_frame_as_the_message_object(msg_id):
    snapshot = make_snapshot()
    values = messages.FIELDS[msg_id](snapshot, CONTEXT)
    message = messages.BUILDERS[msg_id](snapshot, CONTEXT)
    assert values is not None and message is not None
    assert message.get_msgId() == msg_id
    fmt = framing.fields_format(msg_id)
    assert len(values) == fmt.field_count
    assert framing.encode_fields(fmt, values, 3, 7, 1) == framing.encode(message, 3, 7, 1)


def test_a_value_out_of_its_wire_range_raises_struct_error():
    fmt = framing.fields_format(mavlink2.MAVLINK_MSG_ID_GLOBAL_POSITION_INT)
    with pytest.raises(struct.error):
        framing.encode_fields(fmt, (2**32, 0, 0, 0, 0, 0, 0, 0, 0), 0, 1, 1)


def test_every_stream_of_10_hz_or_more_is_packed_from_fields():
    hot = {
        getattr(mavlink2, f"MAVLINK_MSG_ID_{name}")
        for profile in streams.PROFILES.values()
        for name, rate_hz in profile.items()
        if (rate_hz >= 10.0 or (rate_hz == streams.UNLIMITED and name != "DISTANCE_SENSOR"))
    }
    assert hot <= set(messages.FIELDS)


def test_endpoint_sequence_wraps_and_frames_match_pymavlink():
    """300 polls of a 100 Hz ATTITUDE stream: the link's seq runs 0..255 then 0 again, and
    every frame is what pymavlink would send for the message it carries."""
    vehicle = FakeVehicle()
    client = MavClient()
    rates = dict.fromkeys(streams.STREAMABLE, 0.0) | {"ATTITUDE": 100.0}
    try:
        with make_endpoint(vehicle, peers=(client.address,), stream_rates_hz=rates) as endpoint:
            frames: list[bytes] = []
            for k in range(300):
                vehicle.snapshot = make_snapshot(
                    time_usec=k * 10_000, euler_rad=(0.01 * k, -0.02 * k, 0.0)
                )
                endpoint.poll(k * 0.01)
                while True:
                    try:
                        frames.append(client.sock.recv(65535))
                    except BlockingIOError:
                        break
            types = []
            for k, frame in enumerate(frames):
                (parsed,) = mavlink2.MAVLink(None).parse_buffer(frame)
                types.append(parsed.get_type())
                assert parsed.get_seq() == k % 256
                assert frame == _pymavlink_frame(parsed, k % 256, 1, 1)
            assert types.count("ATTITUDE") == 300
            assert len(frames) > 256
    finally:
        client.close()


@settings(max_examples=200, deadline=None)
@given(head=st.binary(max_size=300), tail=st.binary(min_size=1, max_size=3))
def test_crc_carried_on_equals_one_pass_fast_and_pure_python(head, tail):
    """encode_fields chains the CRC over body then CRC extra: equal to one pass over both."""
    one_pass = mavcrc.x25crc(head + tail).crc  # pymavlink's own CRC, one pass
    assert framing._crc_from(tail, framing._crc_from(head, 0xFFFF)) == one_pass
    assert framing._crc_python(tail, framing._crc_python(head, 0xFFFF)) == one_pass


@pytest.mark.parametrize("dialect", [mavlink1, mavlink2], ids=["v1", "v2"])
def test_a_frames_source_and_message_id_are_read_from_its_header(dialect):
    mav = dialect.MAVLink(None, srcSystem=7, srcComponent=100)
    frame = dialect.MAVLink_heartbeat_message(dialect.MAV_TYPE_CAMERA, 8, 0, 0, 4, 3).pack(mav)
    assert frame[0] == (0xFE if dialect is mavlink1 else 0xFD)
    assert framing.source_and_msgid(frame) == (7, 100, dialect.MAVLINK_MSG_ID_HEARTBEAT)
    ping = dialect.MAVLink_ping_message(1, 2, 0, 0).pack(mav)
    assert framing.source_and_msgid(ping) == (7, 100, dialect.MAVLINK_MSG_ID_PING)


@pytest.mark.parametrize("junk", [b"", b"\xfd\x00", b"\x00" * 20, b"\xfe\x01\x02"])
def test_a_truncated_or_foreign_frame_has_no_source(junk):
    assert framing.source_and_msgid(junk) is None
