"""The simulation clock for companion processes of an unpaced run (``SWARMSITL_CLOCK_FILE``).

A lockstep run goes as fast as the CPU allows, so no wall-clock formula gives its time. The
harness keeps the simulation time in a small memory-mapped file that ``companion.clock`` reads
(one little-endian float64, seconds); writing it costs one ``struct.pack_into``.
"""

from __future__ import annotations

import mmap
import struct
from pathlib import Path

CLOCK_FORMAT = "<d"
"""Layout of the file, as ``companion.clock.CLOCK_FORMAT`` reads it."""


def read_time_s(path: Path) -> float:
    """The simulation time a clock file at ``path`` holds, s."""
    with path.open("rb") as f:
        return struct.unpack(CLOCK_FORMAT, f.read(struct.calcsize(CLOCK_FORMAT)))[0]


def ack_dir(clock: Path) -> Path:
    """Where the processes reading ``clock`` acknowledge the time they have seen.

    The name ``companion.clock.ack_dir`` gives it; ``harness.run.lockstep`` reads them.
    """
    return clock.with_name(clock.name + ".acks")


class ClockFile:
    """Publishes the simulation time at ``path`` (created or truncated)."""

    def __init__(self, path: Path) -> None:
        self.path = path = path.absolute()  # other processes, in other directories, open it
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("wb") as f:
            f.write(struct.pack(CLOCK_FORMAT, 0.0))
        self._file = path.open("r+b")
        self._map = mmap.mmap(self._file.fileno(), 8)

    def publish(self, time_s: float) -> None:
        """Make ``time_s`` the time every reader sees."""
        struct.pack_into(CLOCK_FORMAT, self._map, 0, time_s)

    def close(self) -> None:
        """Release the mapping (the file stays, holding the last time)."""
        if not self._map.closed:
            self._map.flush()
            self._map.close()
            self._file.close()
