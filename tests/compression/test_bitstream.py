import struct
import zlib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from compression.bitstream import (
    FORMAT_VERSION,
    HEADER_BYTES,
    MAGIC,
    Payload,
    pack,
    read_header,
    unpack,
)
from compression.errors import ModelMismatchError, StreamError

MODEL_ID = bytes(range(8))


def _stream(escapes=(3, -700, 2**40), words=(1, 2, 0xFFFFFFFF)) -> bytes:
    payload = Payload(np.array(escapes, dtype=np.int64), np.array(words, dtype=np.uint32))
    return pack(MODEL_ID, 3, 240, 321, payload)


def test_round_trip_keeps_header_and_payload():
    data = _stream()
    header, payload = unpack(data)
    assert (header.version, header.model_id, header.level) == (FORMAT_VERSION, MODEL_ID, 3)
    assert (header.height, header.width) == (240, 321)
    assert payload.escapes.tolist() == [3, -700, 2**40]
    assert payload.words.tolist() == [1, 2, 0xFFFFFFFF]
    assert data[:4] == MAGIC


@given(st.lists(st.integers(-(2**62), 2**62), max_size=50))
def test_escaped_values_round_trip(values):
    payload = Payload(np.array(values, dtype=np.int64), np.zeros(0, dtype=np.uint32))
    _, back = unpack(pack(MODEL_ID, 1, 1, 1, payload))
    assert back.escapes.tolist() == values


@pytest.mark.parametrize("keep", [0, 3, HEADER_BYTES - 1, HEADER_BYTES, HEADER_BYTES + 5])
def test_truncated_stream_raises(keep):
    with pytest.raises(StreamError, match="truncated"):
        read_header(_stream()[:keep])


def test_every_flipped_bit_is_caught():
    data = _stream()
    for i in range(len(data)):
        for bit in (0, 5):
            damaged = bytearray(data)
            damaged[i] ^= 1 << bit
            with pytest.raises(StreamError):
                unpack(bytes(damaged))


def test_foreign_bytes_and_types_raise():
    with pytest.raises(StreamError, match="magic"):
        read_header(b"\x89PNG" + bytes(40))
    with pytest.raises(StreamError, match="bytes"):
        read_header("SWAE")  # type: ignore[arg-type]


def test_other_format_version_is_a_model_mismatch():
    data = bytearray(_stream())
    data[4] = FORMAT_VERSION + 1
    head = bytes(data[: HEADER_BYTES - 4])
    crc = zlib.crc32(bytes(data[HEADER_BYTES:]), zlib.crc32(head))
    data[HEADER_BYTES - 4 : HEADER_BYTES] = struct.pack(">I", crc)
    with pytest.raises(ModelMismatchError, match="format version"):
        read_header(bytes(data))
