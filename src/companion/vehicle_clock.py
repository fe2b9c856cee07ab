"""The vehicle's own clock, read from its timestamped telemetry.

A companion that waits "5 s" with a wall-clock sleep waits 5 s of simulated time only if the
simulation keeps its nominal speed; on a loaded machine a paced simulation falls behind and the
wait ends early in simulated time. The autopilot stamps its telemetry with its time since boot
(PX4: ``time_boot_ms``, the simulation clock under swarmsitl, the hardware clock on a real
vehicle), so waiting on *that* clock means the same thing everywhere.

:class:`VehicleClock` is fed timestamps (microseconds) from any telemetry stream that carries them
(MAVSDK's ``telemetry.attitude_quaternion()`` ``timestamp_us``, ATTITUDE_QUATERNION at 50 Hz in
PX4's onboard profile) and lets coroutines sleep until the vehicle's clock has advanced.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterable, Callable


class VehicleClockError(Exception):
    """The vehicle's clock stopped advancing (no telemetry) within the wall-clock limit."""


class VehicleClock:
    """Time since boot of one vehicle, in seconds, advanced by its telemetry timestamps."""

    def __init__(self) -> None:
        self._now_us: int | None = None
        self._changed = asyncio.Event()

    @property
    def started(self) -> bool:
        """True once a timestamp arrived."""
        return self._now_us is not None

    @property
    def now_s(self) -> float:
        """Latest vehicle time, s (raises VehicleClockError before the first timestamp)."""
        if self._now_us is None:
            raise VehicleClockError("no timestamped telemetry received yet")
        return self._now_us * 1e-6

    def feed(self, timestamp_us: int) -> None:
        """Take one telemetry timestamp, us. Older or zero stamps are ignored (reordering)."""
        stamp = int(timestamp_us)
        if stamp <= 0 or (self._now_us is not None and stamp <= self._now_us):
            return
        self._now_us = stamp
        self._changed.set()

    async def follow(self, stamps: AsyncIterable[int]) -> None:
        """Feed every timestamp of ``stamps``; run this as a task for the whole flight."""
        async for stamp in stamps:
            self.feed(stamp)

    async def wait_started(self, timeout_wall_s: float) -> float:
        """Wait for the first timestamp; return the vehicle time, s."""
        await self._wait_until(lambda: self._now_us is not None, timeout_wall_s, "first timestamp")
        return self.now_s

    async def sleep(self, duration_s: float, timeout_wall_s: float) -> float:
        """Return once the vehicle's clock advanced by ``duration_s``; returns the end time, s.

        Args:
            duration_s: vehicle (simulated) seconds to wait.
            timeout_wall_s: wall-clock limit, so a vehicle that stops sending telemetry does not
                hang the caller (raises VehicleClockError).
        """
        start = await self.wait_started(timeout_wall_s)
        end_us = round((start + duration_s) * 1e6)
        await self._wait_until(
            lambda: self._now_us is not None and self._now_us >= end_us,
            timeout_wall_s,
            f"{duration_s:g} s of vehicle time",
        )
        return self.now_s

    async def _wait_until(self, done: Callable[[], bool], timeout_wall_s: float, what: str) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout_wall_s
        while not done():
            self._changed.clear()
            remaining = deadline - loop.time()
            if remaining <= 0:
                raise VehicleClockError(f"vehicle clock: no {what} within {timeout_wall_s:g} s")
            try:
                await asyncio.wait_for(self._changed.wait(), remaining)
            except TimeoutError:
                continue
