"""The companion's view of time: wall time scaled by the simulation speed factor.

On a real vehicle the factor is 1. Under swarmsitl the harness exports ``SWARMSITL_SPEED`` to the
companion processes it starts, so that "hover for 5 s" means 5 s of *simulated* time whether the
simulation runs paced at 1x or 10x. It also exports ``SWARMSITL_CLOCK_ORIGIN``, the system-wide
monotonic time (``time.monotonic()``, CLOCK_MONOTONIC) at which the paced simulation's time was
zero, so that ``now_s`` reads the simulation's time (as long as the simulation keeps its pace) and
the times companions record (message latencies, task intervals) line up with the simulation's.
"""

from __future__ import annotations

import asyncio
import os
import time


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
    return (time.monotonic() - origin_s()) * speed_factor()


async def sleep(duration_s: float) -> None:
    """Sleep for ``duration_s`` simulated seconds."""
    await asyncio.sleep(duration_s / speed_factor())
