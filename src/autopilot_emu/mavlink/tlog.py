"""Telemetry log (.tlog) writer, the format QGroundControl and MAVProxy record.

Each record is an 8-byte big-endian unsigned microsecond Unix timestamp followed by one raw
MAVLink frame, exactly as it went over the wire. pymavlink reads such files with
``mavutil.mavlink_connection(path)`` and ``mavlogdump.py``. Timestamps come from the simulation
clock (Unix time at t = 0 plus simulation time), never from the wall clock.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import BinaryIO

_TIMESTAMP = struct.Struct(">Q")


class TlogWriter:
    """Appends frames to one .tlog file, opened on the first write.

    Args:
        path: file to append to; parent directories are created.
        epoch_start_s: Unix time at simulation t = 0, s.
    """

    def __init__(self, path: Path, epoch_start_s: float) -> None:
        self.path = Path(path)
        self._epoch_start_us = round(epoch_start_s * 1e6)
        self._file: BinaryIO | None = None
        self._closed = False
        self.frames_written = 0
        """Frames appended so far."""

    def write(self, sim_time_s: float, frame: bytes) -> None:
        """Append ``frame`` stamped with the Unix time of simulation instant ``sim_time_s``."""
        if self._file is None:
            if self._closed:
                return
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("ab")
        stamp_us = self._epoch_start_us + round(sim_time_s * 1e6)
        self._file.write(_TIMESTAMP.pack(max(0, stamp_us)) + frame)
        self.frames_written += 1

    def flush(self) -> None:
        """Push buffered records to the operating system."""
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        """Flush and close; later writes are dropped."""
        self._closed = True
        if self._file is not None:
            self._file.close()
            self._file = None
