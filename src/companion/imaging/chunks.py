"""One encoded image over several datagrams: split into chunks, reassemble with loss and reordering.

A datagram carries at most ``companion.net.MAX_DATAGRAM_BYTES`` (65507, UDP over IPv4); an encoded
camera frame may be larger. Each chunk is one message of topic ``CHUNK_TOPIC`` whose body is a
dict ``{"f": frame id, "i": index, "n": count, "m": metadata, "d": bytes}``. The metadata (level,
capture time, origin, ...) rides in every chunk, so any chunk opens the frame.

The receiver keeps incomplete frames until every chunk has arrived, in any order (duplicates are
ignored). A frame still missing a chunk ``timeout_s`` after its first chunk arrived, or pushed out
by newer frames (``max_frames``), is dropped and counted: UDP does not retransmit, and an image
late by a whole period is worth less than the next one. A malformed chunk is counted, never raised.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

from companion.net import MAX_DATAGRAM_BYTES

CHUNK_TOPIC = "image_chunk"
"""Topic of image chunks."""
ENVELOPE_HEADROOM_BYTES = 1024
"""Room kept in a datagram for the envelope, the chunk's fields and its metadata, bytes."""
MAX_CHUNK_BYTES = MAX_DATAGRAM_BYTES - ENVELOPE_HEADROOM_BYTES
"""Largest image bytes per chunk."""


def split(
    frame_id: int, data: bytes, meta: dict[str, Any], chunk_bytes: int
) -> list[dict[str, Any]]:
    """The chunk bodies of one encoded image (at least one, also for empty data)."""
    if not 1 <= chunk_bytes <= MAX_CHUNK_BYTES:
        raise ValueError(f"chunk_bytes: must be within 1..{MAX_CHUNK_BYTES}, got {chunk_bytes}")
    count = max(1, math.ceil(len(data) / chunk_bytes))
    return [
        {
            "f": frame_id,
            "i": i,
            "n": count,
            "m": meta,
            "d": data[i * chunk_bytes : (i + 1) * chunk_bytes],
        }
        for i in range(count)
    ]


@dataclass
class Frame:
    """A reassembled image: its sender, id, metadata, bytes and when its last chunk arrived."""

    src: str
    frame_id: int
    meta: dict[str, Any]
    data: bytes
    first_s: float
    """Receiver clock at its first chunk, s."""
    complete_s: float
    """Receiver clock at its last chunk, s."""
    chunks: int


@dataclass
class _Partial:
    meta: dict[str, Any]
    count: int
    first_s: float
    parts: dict[int, bytes] = field(default_factory=dict)


@dataclass
class ReassemblyCounts:
    """What the reassembler saw."""

    chunks: int = 0
    """Valid chunks received (duplicates included)."""
    duplicates: int = 0
    """Chunks received again (ignored)."""
    malformed: int = 0
    """Chunk bodies that were not valid (dropped)."""
    frames: int = 0
    """Frames completed."""
    incomplete: int = 0
    """Frames dropped with chunks missing (timeout, evicted, or still open at the end)."""
    late_chunks: int = 0
    """Chunks of a frame already completed or dropped (ignored)."""
    missing: int = 0
    """Frames of which no chunk arrived: gaps in a sender's frame ids (0, 1, 2, ...) below the
    highest seen (a frame lost whole after the last one seen cannot be told)."""


class Reassembler:
    """Collects chunks per (sender, frame id) and hands back complete frames."""

    def __init__(self, timeout_s: float = 5.0, max_frames: int = 32) -> None:
        if not timeout_s > 0:
            raise ValueError(f"timeout_s: must be > 0, got {timeout_s}")
        if max_frames < 1:
            raise ValueError(f"max_frames: must be >= 1, got {max_frames}")
        self.timeout_s = timeout_s
        self.max_frames = max_frames
        self.counts = ReassemblyCounts()
        self._open: OrderedDict[tuple[str, int], _Partial] = OrderedDict()
        self._closed: OrderedDict[tuple[str, int], None] = OrderedDict()
        self._seen: dict[str, tuple[int, int]] = {}  # src -> (highest frame id, frames seen)

    def add(self, src: str, body: object, now_s: float) -> Frame | None:
        """Take one chunk; return the frame it completes, else None."""
        self.expire(now_s)
        if not _valid(body):
            self.counts.malformed += 1
            return None
        assert isinstance(body, dict)
        key = (src, body["f"])
        if key in self._closed:
            self.counts.late_chunks += 1
            return None
        partial = self._open.get(key)
        if partial is None:
            partial = self._open[key] = _Partial(body["m"], body["n"], now_s)
            highest, seen = self._seen.get(src, (-1, 0))
            self._seen[src] = (max(highest, key[1]), seen + 1)
            self.counts.missing = sum(max(0, h + 1 - n) for h, n in self._seen.values())
            while len(self._open) > self.max_frames:
                old, _ = self._open.popitem(last=False)
                self._close(old, complete=False)
        elif partial.count != body["n"]:
            self.counts.malformed += 1
            return None
        self.counts.chunks += 1
        if body["i"] in partial.parts:
            self.counts.duplicates += 1
            return None
        partial.parts[body["i"]] = body["d"]
        if len(partial.parts) < partial.count:
            return None
        del self._open[key]
        self._close(key, complete=True)
        data = b"".join(partial.parts[i] for i in range(partial.count))
        return Frame(src, key[1], partial.meta, data, partial.first_s, now_s, partial.count)

    def expire(self, now_s: float) -> int:
        """Drop frames open for longer than ``timeout_s``; return how many."""
        old = [k for k, p in self._open.items() if now_s - p.first_s > self.timeout_s]
        for key in old:
            del self._open[key]
            self._close(key, complete=False)
        return len(old)

    def flush(self) -> int:
        """Drop every open frame (the end of a run); return how many."""
        keys = list(self._open)
        for key in keys:
            del self._open[key]
            self._close(key, complete=False)
        return len(keys)

    @property
    def open_frames(self) -> int:
        """Frames waiting for chunks."""
        return len(self._open)

    def _close(self, key: tuple[str, int], complete: bool) -> None:
        if complete:
            self.counts.frames += 1
        else:
            self.counts.incomplete += 1
        self._closed[key] = None
        while len(self._closed) > 4 * self.max_frames:
            self._closed.popitem(last=False)


def _valid(body: object) -> bool:
    if not isinstance(body, dict):
        return False
    f, i, n, m, d = (body.get(k) for k in ("f", "i", "n", "m", "d"))
    ints = all(isinstance(v, int) and not isinstance(v, bool) for v in (f, i, n))
    return ints and isinstance(m, dict) and isinstance(d, bytes) and n >= 1 and 0 <= i < n
