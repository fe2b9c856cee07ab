"""The records of a .tlog, read so that a cut or corrupt file never stops the reading.

A tlog is a sequence of records: an 8-byte big-endian Unix timestamp in microseconds followed by
one MAVLink frame as it went over the wire (``autopilot_emu.mavlink.tlog``, QGroundControl,
MAVProxy). :func:`scan_tlog` walks the records by their frame lengths, decodes with pymavlink only
the frames the caller keeps (chosen from the header: message id, system, component, so that the
high-rate streams cost next to nothing), and

- stops at a last record cut short (a run killed mid-write), reporting where;
- steps over bytes that are no record (a corrupt stretch) to the next record that decodes with a
  valid checksum and a timestamp within a day of the previous one, reporting what it skipped.

pymavlink's own file reader (``mavutil.mavlink_connection(path)``, an mmap index of the file)
raises on some corrupt files; this walker is why a report can still be written from them.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as mavlink2

_STAMP = struct.Struct(">Q")
_V2_HEADER, _V1_HEADER, _CRC, _SIGNATURE = 10, 6, 2, 13
_MARKERS = (mavlink2.PROTOCOL_MARKER_V2, mavlink2.PROTOCOL_MARKER_V1)
RESYNC_WINDOW_S = 86_400.0
"""A record found after a corrupt stretch must be stamped within this of the last good one, s."""


@dataclass
class TlogScan:
    """What :func:`scan_tlog` found."""

    records: list[tuple[float, mavlink2.MAVLink_message]] = field(default_factory=list)
    """(stamp as Unix time in s, decoded message) of every kept frame, in file order."""
    frames: int = 0
    """Whole frames walked over (kept or not)."""
    cut_at: int | None = None
    """Byte offset of a last record cut short; None when the file ends with a whole record."""
    skipped: list[tuple[int, int]] = field(default_factory=list)
    """(offset, length) of each stretch of bytes that was no record."""
    bad_checksums: int = 0
    """Kept frames whose checksum (or content) did not decode."""

    def problems(self, name: str, size: int) -> list[str]:
        """One sentence per kind of damage, naming the file ``name`` of ``size`` bytes."""
        out = []
        if self.cut_at is not None:
            out.append(
                f"{name}: the last {size - self.cut_at} byte(s), from byte {self.cut_at}, are no "
                "whole record (run interrupted?); read the records before them"
            )
        if self.skipped:
            total = sum(n for _, n in self.skipped)
            out.append(
                f"{name}: skipped {len(self.skipped)} corrupt stretch(es), {total} byte(s), the "
                f"first at byte {self.skipped[0][0]}"
            )
        if self.bad_checksums:
            out.append(f"{name}: {self.bad_checksums} frame(s) failed their checksum; left out")
        return out


def _frame_size(data: bytes, start: int) -> int | None:
    """Length of the frame starting at ``start`` from its header; None if no frame starts there."""
    marker = data[start]
    if marker == mavlink2.PROTOCOL_MARKER_V2:
        size = _V2_HEADER + data[start + 1] + _CRC
        if data[start + 2] & mavlink2.MAVLINK_IFLAG_SIGNED:
            size += _SIGNATURE
        return size
    if marker == mavlink2.PROTOCOL_MARKER_V1:
        return _V1_HEADER + data[start + 1] + _CRC
    return None


def _header(data: bytes, start: int) -> tuple[int, int, int]:
    """(msgid, sysid, compid) of the frame at ``start``."""
    if data[start] == mavlink2.PROTOCOL_MARKER_V2:
        msgid = data[start + 7] | (data[start + 8] << 8) | (data[start + 9] << 16)
        return msgid, data[start + 5], data[start + 6]
    return data[start + 5], data[start + 3], data[start + 4]


def _header_fits(data: bytes, start: int) -> bool:
    need = _V2_HEADER if data[start] == mavlink2.PROTOCOL_MARKER_V2 else _V1_HEADER
    return start + need <= len(data)


def _decodes(mav: mavlink2.MAVLink, frame: bytes) -> mavlink2.MAVLink_message | None:
    try:
        return mav.decode(bytearray(frame))
    except (mavlink2.MAVError, struct.error, ValueError, IndexError, KeyError):
        return None


def _plausible(mav: mavlink2.MAVLink, data: bytes, ofs: int, last_s: float | None) -> bool:
    """A record starts at ``ofs``: known message, valid checksum, stamp near the last one."""
    start = ofs + _STAMP.size
    if ofs < 0 or start + 3 > len(data) or not _header_fits(data, start):
        return False
    size = _frame_size(data, start)
    if size is None or start + size > len(data):
        return False
    if last_s is not None and abs(_STAMP.unpack_from(data, ofs)[0] * 1e-6 - last_s) > (
        RESYNC_WINDOW_S
    ):
        return False
    if _header(data, start)[0] not in mavlink2.mavlink_map:
        return False
    return _decodes(mav, data[start : start + size]) is not None


def _resync(mav: mavlink2.MAVLink, data: bytes, ofs: int, last_s: float | None) -> int | None:
    """Offset of the next plausible record after a bad one at ``ofs``; None if there is none."""
    p = ofs + _STAMP.size + 1
    while True:
        hits = [h for h in (data.find(bytes([m]), p) for m in _MARKERS) if h >= 0]
        if not hits:
            return None
        p = min(hits)
        if _plausible(mav, data, p - _STAMP.size, last_s):
            return p - _STAMP.size
        p += 1


def scan_tlog(data: bytes, keep: Callable[[int, int, int], bool]) -> TlogScan:
    """Walk the records of tlog bytes ``data``; decode those with ``keep(msgid, sysid, compid)``.

    Only messages of pymavlink's common dialect are decoded (others have no checksum seed to
    verify them with) and kept.
    """
    mav = mavlink2.MAVLink(None)
    scan = TlogScan()
    ofs, n = 0, len(data)
    last_s: float | None = None
    v2, known, stamp_at = mavlink2.PROTOCOL_MARKER_V2, mavlink2.mavlink_map, _STAMP.unpack_from
    while ofs < n:
        start = ofs + _STAMP.size
        # Fast path (inlined: most of a long tlog): a whole MAVLink 2 record in sequence.
        if start + _V2_HEADER <= n and data[start] == v2:
            size = _V2_HEADER + data[start + 1] + _CRC
            if data[start + 2] & mavlink2.MAVLINK_IFLAG_SIGNED:
                size += _SIGNATURE
            stamp_s = stamp_at(data, ofs)[0] * 1e-6
            if start + size <= n and (last_s is None or abs(stamp_s - last_s) <= RESYNC_WINDOW_S):
                scan.frames += 1
                msgid = data[start + 7] | (data[start + 8] << 8) | (data[start + 9] << 16)
                if msgid in known and keep(msgid, data[start + 5], data[start + 6]):
                    _keep_frame(scan, mav, stamp_s, data[start : start + size])
                last_s = stamp_s
                ofs = start + size
                continue
        # Slow path: MAVLink 1, the end of the file, damage.
        if start + 3 > n or (data[start] in _MARKERS and not _header_fits(data, start)):
            scan.cut_at = ofs
            break
        size = _frame_size(data, start)
        stamp_s = stamp_at(data, ofs)[0] * 1e-6
        bad_stamp = last_s is not None and abs(stamp_s - last_s) > RESYNC_WINDOW_S
        if size is None or bad_stamp or start + size > n:
            nxt = _resync(mav, data, ofs, last_s)
            if nxt is None and size is not None and not bad_stamp:
                scan.cut_at = ofs  # a last record cut short
                break
            scan.skipped.append((ofs, (n if nxt is None else nxt) - ofs))
            if nxt is None:
                break
            ofs = nxt
            continue
        scan.frames += 1
        msgid, sysid, compid = _header(data, start)
        if msgid in known and keep(msgid, sysid, compid):
            _keep_frame(scan, mav, stamp_s, data[start : start + size])
        last_s = stamp_s
        ofs = start + size
    return scan


def _keep_frame(scan: TlogScan, mav: mavlink2.MAVLink, stamp_s: float, frame: bytes) -> None:
    msg = _decodes(mav, frame)
    if msg is None:
        scan.bad_checksums += 1
    else:
        scan.records.append((stamp_s, msg))
