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

In lockstep the process is also a participant: when the clock file has an acknowledgement
folder beside it (``<clock file>.acks/``, made by the harness), importing this module starts a
daemon thread that copies the simulation time it reads into ``<folder>/<pid>`` every
ACK_PERIOD_WALL_S. The simulation never runs more than its documented lead ahead of the
slowest acknowledgement of a live process (``harness.run.lockstep``), so a process that is stopped
(SIGSTOP, a debugger) or starved of CPU pauses the simulation instead of missing its time.
"""

from __future__ import annotations

import asyncio
import atexit
import contextlib
import mmap
import os
import struct
import threading
import time
from pathlib import Path

CLOCK_FORMAT = "<d"
"""Layout of the clock file: simulation time, s, little-endian float64."""
POLL_WALL_S = 0.002
"""How often ``sleep`` reads the clock file, wall seconds."""
ACK_PERIOD_WALL_S = 0.002
"""How often a lockstep participant's acknowledgement is refreshed, wall seconds."""

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


def ack_dir(clock: Path) -> Path:
    """The folder where the processes reading ``clock`` acknowledge the time they have seen."""
    return clock.with_name(clock.name + ".acks")


def _acknowledge(clock: Path, ack: Path) -> None:
    """Copy the simulation time from ``clock`` into ``ack`` for as long as the process runs."""
    with clock.open("rb") as f:
        source = mmap.mmap(f.fileno(), 8, access=mmap.ACCESS_READ)
    with ack.open("r+b") as f:
        target = mmap.mmap(f.fileno(), 8)
    while True:
        target[:8] = source[:8]
        time.sleep(ACK_PERIOD_WALL_S)


_acknowledging: threading.Thread | None = None


def start_acknowledging() -> bool:
    """Take part in the lockstep of the simulation behind ``SWARMSITL_CLOCK_FILE``, if it asks.

    Runs on import; idempotent. Returns whether this process acknowledges (False without a
    clock file, or when the harness keeps no acknowledgement folder: paced runs, a real vehicle).
    """
    global _acknowledging
    if _acknowledging is not None and _acknowledging.is_alive():
        return True
    clock = clock_file()
    if clock is None or not ack_dir(clock).is_dir():
        return False
    ack = ack_dir(clock) / str(os.getpid())
    try:
        ack.write_bytes(struct.pack(CLOCK_FORMAT, _read_clock_file(clock)))
    except (OSError, ValueError):  # the run is over, or its clock is not readable
        return False
    atexit.register(_forget, ack)
    _acknowledging = threading.Thread(
        target=_acknowledge, args=(clock, ack), name="swarmsitl-clock-ack", daemon=True
    )
    _acknowledging.start()
    return True


def _forget(ack: Path) -> None:
    """At exit: this process is no longer a participant."""
    with contextlib.suppress(OSError):
        ack.unlink()


start_acknowledging()
