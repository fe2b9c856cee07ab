"""Envelopes round-trip through msgpack; anything malformed raises EnvelopeError only."""

from __future__ import annotations

import contextlib
from dataclasses import replace

import msgpack
import pytest
from hypothesis import given
from hypothesis import strategies as st

from companion.net.envelope import (
    FORMAT_VERSION,
    MAX_DATAGRAM_BYTES,
    Envelope,
    EnvelopeError,
    MessageTooLargeError,
    decode,
    encode,
    encode_fanout,
    route_of,
)

bodies = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64 - 1)
    | st.floats(allow_nan=False)
    | st.text(max_size=20)
    | st.binary(max_size=20),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=10,
)

envelopes = st.builds(
    Envelope,
    src=st.text(max_size=10),
    dst=st.text(max_size=10),
    kind=st.sampled_from(["msg", "request", "reply"]),
    topic=st.text(max_size=10),
    msg_id=st.integers(0, 2**63),
    reply_to=st.none() | st.integers(0, 2**63),
    category=st.sampled_from(["data", "control"]),
    sent_s=st.floats(allow_nan=False, allow_infinity=False),
    attempt=st.integers(1, 100),
    body=bodies,
)


def sample(**changes) -> Envelope:
    fields = dict(
        src="edge1",
        dst="fog1",
        kind="request",
        topic="plan",
        msg_id=7,
        reply_to=None,
        category="control",
        sent_s=12.5,
        attempt=2,
        body={"area": [1, 2], "raw": b"\x00\xff"},
    )
    fields.update(changes)
    return Envelope(**fields)


@given(envelopes)
def test_round_trip(env):
    assert decode(encode(env)) == env


@given(st.binary(max_size=200))
def test_random_bytes_raise_only_envelope_error(data):
    with contextlib.suppress(EnvelopeError):
        decode(data)


@given(st.lists(bodies, min_size=0, max_size=13))
def test_random_msgpack_arrays_raise_only_envelope_error(items):
    with contextlib.suppress(EnvelopeError):
        decode(msgpack.packb(items, use_bin_type=True))


@given(st.integers(0, 10), bodies)
def test_valid_envelope_with_one_field_replaced_raises_only_envelope_error(index, value):
    items = valid_items()
    items[index] = value
    with contextlib.suppress(EnvelopeError):
        decode(msgpack.packb(items, use_bin_type=True))


@given(st.binary(min_size=1, max_size=8), st.integers(0, 60))
def test_corrupted_envelope_bytes_raise_only_envelope_error(garbage, position):
    data = bytearray(encode(sample()))
    data[position : position + len(garbage)] = garbage
    with contextlib.suppress(EnvelopeError):
        decode(bytes(data))


def valid_items() -> list:
    return msgpack.unpackb(encode(sample()), raw=False)


@pytest.mark.parametrize(
    ("index", "value", "message"),
    [
        (0, FORMAT_VERSION + 1, "version"),
        (0, float(FORMAT_VERSION), "version"),
        (8, float("nan"), "'sent_s'"),
        (8, float("inf"), "'sent_s'"),
        (1, 5, "'src'"),
        (3, "push", "'kind'"),
        (5, "7", "'msg_id'"),
        (5, True, "'msg_id'"),
        (6, 1.5, "'reply_to'"),
        (7, "bulk", "'category'"),
        (8, None, "'sent_s'"),
        (9, 0, "'attempt'"),
    ],
)
def test_bad_field_is_named(index, value, message):
    items = valid_items()
    items[index] = value
    with pytest.raises(EnvelopeError, match=message):
        decode(msgpack.packb(items, use_bin_type=True))


def test_missing_field_and_non_msgpack_are_rejected():
    with pytest.raises(EnvelopeError, match="elements"):
        decode(msgpack.packb(valid_items()[:-1]))
    with pytest.raises(EnvelopeError, match="array"):
        decode(msgpack.packb({"v": 1}))
    with pytest.raises(EnvelopeError, match="msgpack"):
        decode(b"\xc1")


def test_oversized_envelope_names_size_and_limit():
    body = b"x" * MAX_DATAGRAM_BYTES
    with pytest.raises(MessageTooLargeError, match=r"\d+ bytes, above the 65507-byte") as info:
        encode(sample(body=body))
    assert info.value.size_bytes > MAX_DATAGRAM_BYTES


def test_largest_envelope_that_fits_encodes_to_the_limit():
    """A body sized to fill the datagram exactly is accepted; one byte more is not."""
    fixed = len(encode(sample(body=b""))) - 2  # msgpack bin8 header of b"" is 2 bytes
    body = b"x" * (MAX_DATAGRAM_BYTES - fixed - 3)  # bin16 header: 3 bytes
    assert len(encode(sample(body=body))) == MAX_DATAGRAM_BYTES
    with pytest.raises(MessageTooLargeError):
        encode(sample(body=body + b"x"))


def test_route_of_reads_src_and_dst_only():
    assert route_of(encode(sample(body=b"x" * 60000))) == ("edge1", "fog1")
    items = valid_items()
    items[0] = FORMAT_VERSION + 1
    with pytest.raises(EnvelopeError, match="version"):
        route_of(msgpack.packb(items, use_bin_type=True))


@given(st.binary(max_size=100))
def test_route_of_random_bytes_raise_only_envelope_error(data):
    with contextlib.suppress(EnvelopeError):
        route_of(data)


def test_numpy_values_arrive_as_lists_and_numbers():
    import numpy as np

    body = {"pos_m": np.array([1.0, 2.0, -3.5]), "count": np.int64(7), "pair": (1, 2)}
    assert decode(encode(sample(body=body))).body == {
        "pos_m": [1.0, 2.0, -3.5],
        "count": 7,
        "pair": [1, 2],
    }


def test_unencodable_body_names_its_type():
    with pytest.raises(TypeError, match="cannot encode a set"):
        encode(sample(body={1, 2}))


@given(
    envelopes,
    st.lists(st.text(max_size=40), min_size=1, max_size=5),
    st.sampled_from([0, 126, 127, 254, 255, 65534, 65535, 2**32 - 2, 2**63 - 3]),
)
def test_fanout_is_byte_for_byte_one_encode_per_recipient(env, dsts, first_id):
    """Each spliced datagram equals ``encode`` of its own envelope, across msgpack's size
    classes (msg_ids crossing 1-, 2-, 4- and 8-byte integers; destination names of every
    string header)."""
    template = replace(env, msg_id=first_id)
    expected = [
        encode(replace(template, dst=dst, msg_id=first_id + k)) for k, dst in enumerate(dsts)
    ]
    assert encode_fanout(template, dsts) == expected


def test_fanout_converts_numpy_and_integer_times_as_encode_does():
    """Numpy bodies and an integer ``sent_s`` splice to exactly what ``encode`` gives."""
    import numpy as np

    template = sample(body={"p": np.array([1.0, 2.5]), "n": np.int64(3)}, sent_s=4)
    got = encode_fanout(template, ["a", "b" * 300])
    assert got == [
        encode(replace(template, dst="a")),
        encode(replace(template, dst="b" * 300, msg_id=8)),
    ]
    assert decode(got[1]).body == {"p": [1.0, 2.5], "n": 3}


def test_fanout_raises_for_the_first_datagram_too_large():
    """The first copy above the limit raises with its own size (a longer dst tips it over)."""
    fixed = len(encode(sample(dst="x", body=b""))) - 2  # bin8 header of b"": 2 bytes
    template = sample(body=b"\x00" * (MAX_DATAGRAM_BYTES - fixed - 3))  # bin16 header: 3 bytes
    assert len(encode_fanout(template, ["x"])[0]) == MAX_DATAGRAM_BYTES
    with pytest.raises(MessageTooLargeError) as info:
        encode_fanout(template, ["x", "xy", "xyz"])
    assert info.value.size_bytes == MAX_DATAGRAM_BYTES + 1


def test_fanout_to_nobody_encodes_nothing():
    """No recipients: no datagram, and the body is not even looked at (as with no encode)."""
    assert encode_fanout(sample(body={1, 2}), []) == []
    with pytest.raises(TypeError, match="cannot encode a set"):
        encode_fanout(sample(body={1, 2}), ["fog1"])
