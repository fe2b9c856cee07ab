"""The companion's view of time: wall time scaled by the simulation speed factor.

On a real vehicle the factor is 1. Under swarmsitl the harness exports ``SWARMSITL_SPEED`` to the
companion processes it starts, so that "hover for 5 s" means 5 s of *simulated* time whether the
simulation runs paced at 1x or 10x. It also exports ``SWARMSITL_CLOCK_ORIGIN``, the system-wide
monotonic time (``time.monotonic()``, CLOCK_MONOTONIC) at which the paced simulation's time was
zero, so that ``now_s`` reads the simulation's time (as long as the simulation keeps its pace) and
the times companions record (message latencies, task intervals) line up with the simulation's.

A run that is not paced (``swarmsitl run --lockstep``: the simulation as fast as the CPU allows)
has no speed factor; the harness then exports ``SWARMSITL_CLOCK_FILE``, a file holding the
simulation time as one little-endian float64 (seconds) that it rewrites as the simulation
advances. ``now_s`` and ``sleep`` read that file instead, so the companion's waits are simulated
seconds whatever the pace. Without any variable (a real vehicle) both are the monotonic clock.
"""

from __future__ import annotations

import asyncio
import mmap
import os
import struct
import time
from pathlib import Path

CLOCK_FORMAT = "<d"
"""Layout of the clock file: simulation time, s, little-endian float64."""
POLL_WALL_S = 0.002
"""How often ``sleep`` reads the clock file, wall seconds."""

_clock_map: tuple[str, mmap.mmap] | None = None


def clock_file() -> Path | None:
    """The simulation's clock file (``SWARMSITL_CLOCK_FILE``), or None when there is none."""
    value = os.environ.get("SWARMSITL_CLOCK_FILE")
    return Path(value) if value else None


def _read_clock_file(path: Path) -> float:
    """Simulation time stored in ``path``, s (mapped once per process)."""
    global _clock_map
    if _clock_map is None or _clock_map[0] != str(path):
        with path.open("rb") as f:
            _clock_map = (str(path), mmap.mmap(f.fileno(), 8, access=mmap.ACCESS_READ))
    return struct.unpack_from(CLOCK_FORMAT, _clock_map[1])[0]


def speed_factor() -> float:
    """Simulation seconds per wall second (1.0 on real hardware)."""
    try:
        value = float(os.environ.get("SWARMSITL_SPEED", "1.0"))
    except ValueError:
        return 1.0
    return value if value > 0 else 1.0


def origin_s() -> float:
    """Monotonic time at which simulated time was zero (``SWARMSITL_CLOCK_ORIGIN``), else 0."""
    try:
        value = float(os.environ.get("SWARMSITL_CLOCK_ORIGIN", "0"))
    except ValueError:
        return 0.0
    return value if value == value else 0.0  # NaN: no origin


def now_s() -> float:
    """Monotonic time in simulated seconds (the simulation's time under swarmsitl)."""
    path = clock_file()
    if path is not None:
        return _read_clock_file(path)
    return (time.monotonic() - origin_s()) * speed_factor()


async def sleep(duration_s: float) -> None:
    """Sleep for ``duration_s`` simulated seconds."""
    path = clock_file()
    if path is None:
        await asyncio.sleep(duration_s / speed_factor())
        return
    end = _read_clock_file(path) + duration_s
    while _read_clock_file(path) < end:
        await asyncio.sleep(POLL_WALL_S)
