"""Chunking an encoded image over datagrams: reordering, duplicates, loss and junk are survived."""

from __future__ import annotations

import numpy as np
import pytest

from companion.imaging.chunks import MAX_CHUNK_BYTES, Reassembler, split
from companion.net import Envelope, encode

META = {"level": 3, "capture_s": 1.0}


def payload(size: int, seed: int = 0) -> bytes:
    return np.random.default_rng(seed).bytes(size)


def test_every_chunk_of_the_largest_size_fits_one_datagram():
    """A chunk of MAX_CHUNK_BYTES with its metadata and envelope stays under the UDP limit."""
    meta = {"origin": "edge-with-a-long-name", "origin_frame": 2**40, "level": 5}
    meta |= {"capture_s": 1e9 / 3, "sent_s": 1e9 / 7, "width_px": 4096, "height_px": 4096}
    bodies = split(2**40, payload(3 * MAX_CHUNK_BYTES + 5), meta, MAX_CHUNK_BYTES)
    assert [len(b["d"]) for b in bodies] == [MAX_CHUNK_BYTES] * 3 + [5]
    env = Envelope("edge-with-a-long-name", "fog-with-a-long-name", "msg", "image_chunk",
                   2**40, None, "data", 1e9, 1, bodies[0])  # fmt: skip
    encode(env)  # raises MessageTooLargeError if not
    with pytest.raises(ValueError, match="chunk_bytes"):
        split(0, b"x", META, MAX_CHUNK_BYTES + 1)


def test_reordered_and_duplicated_chunks_reassemble_the_same_bytes():
    data = payload(10_000)
    bodies = split(7, data, META, 1000)
    order = np.random.default_rng(1).permutation(len(bodies))
    reassembler = Reassembler(timeout_s=5.0)
    done = [reassembler.add("edge1", bodies[i], 0.1 * k) for k, i in enumerate(order)]
    reassembler.add("edge1", bodies[0], 2.0)  # a duplicate after completion
    frames = [f for f in done if f is not None]
    assert len(frames) == 1 and done[-1] is frames[0]
    assert frames[0].data == data and frames[0].meta == META and frames[0].chunks == 10
    assert reassembler.counts.frames == 1 and reassembler.counts.late_chunks == 1


def test_a_frame_missing_a_chunk_is_dropped_and_counted_and_the_next_one_arrives():
    reassembler = Reassembler(timeout_s=2.0)
    first = split(1, payload(5000, 1), META, 1000)
    second = split(2, payload(5000, 2), META, 1000)
    for body in first[:2] + first[3:]:  # chunk 2 lost
        assert reassembler.add("edge1", body, 0.0) is None
    assert reassembler.open_frames == 1
    frames = [reassembler.add("edge1", body, 5.0) for body in second]
    assert frames[-1] is not None and frames[-1].data == payload(5000, 2)
    assert reassembler.counts.incomplete == 1  # expired at 5.0 s (> 2 s after its first chunk)
    assert reassembler.add("edge1", first[2], 5.1) is None  # too late: ignored
    assert reassembler.counts.late_chunks == 1


def test_frames_of_different_senders_do_not_mix():
    reassembler = Reassembler()
    a, b = split(1, b"a" * 30, META, 10), split(1, b"b" * 30, META, 10)
    out = []
    for chunk_a, chunk_b in zip(a, b, strict=True):
        out += [reassembler.add("e1", chunk_a, 0.0), reassembler.add("e2", chunk_b, 0.0)]
    assert [f.data for f in out if f is not None] == [b"a" * 30, b"b" * 30]


def test_too_many_open_frames_evict_the_oldest():
    reassembler = Reassembler(timeout_s=100.0, max_frames=2)
    for frame_id in range(4):
        reassembler.add("edge1", split(frame_id, b"xy", META, 1)[0], 0.0)
    assert reassembler.open_frames == 2 and reassembler.counts.incomplete == 2
    assert reassembler.flush() == 2 and reassembler.counts.incomplete == 4


@pytest.mark.parametrize(
    "body",
    [
        None,
        b"junk",
        {"f": 1, "i": 0, "n": 1, "m": {}},  # no data
        {"f": 1, "i": 1, "n": 1, "m": {}, "d": b""},  # index out of range
        {"f": "1", "i": 0, "n": 1, "m": {}, "d": b""},
        {"f": 1, "i": 0, "n": 0, "m": {}, "d": b""},
        {"f": 1, "i": 0, "n": 1, "m": [], "d": b""},
        {"f": True, "i": 0, "n": 1, "m": {}, "d": b""},
    ],
)
def test_malformed_chunks_are_counted_not_raised(body):
    reassembler = Reassembler()
    assert reassembler.add("edge1", body, 0.0) is None
    assert reassembler.counts.malformed == 1 and reassembler.open_frames == 0


def test_a_chunk_disagreeing_on_the_count_is_malformed():
    reassembler = Reassembler()
    reassembler.add("edge1", {"f": 1, "i": 0, "n": 3, "m": {}, "d": b"a"}, 0.0)
    reassembler.add("edge1", {"f": 1, "i": 1, "n": 2, "m": {}, "d": b"b"}, 0.0)
    assert reassembler.counts.malformed == 1 and reassembler.open_frames == 1


def test_a_frame_lost_whole_shows_as_a_gap_in_the_frame_ids():
    reassembler = Reassembler()
    for frame_id in (0, 1, 3, 6):  # 2, 4 and 5 never arrive
        reassembler.add("edge1", split(frame_id, b"x", META, 10)[0], 0.0)
    reassembler.add("edge2", split(0, b"x", META, 10)[0], 0.0)
    assert reassembler.counts.missing == 3 and reassembler.counts.frames == 5
