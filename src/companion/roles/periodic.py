"""Run coroutines on fixed periods of simulated time until a deadline."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

from companion import clock


async def every(period_s: float, end_s: float, action: Callable[[], Awaitable[None]]) -> None:
    """Await ``action()`` at 0, period, 2 period, ... (simulated s) until ``end_s``.

    Periods are counted from the start, so a slow action does not shift the later ones; a
    period missed entirely is skipped, not run twice.
    """
    if not period_s > 0:
        raise ValueError(f"period_s: must be > 0, got {period_s}")
    start_s = clock.now_s()
    k = 0
    while clock.now_s() < end_s:
        await action()
        k = max(k + 1, int((clock.now_s() - start_s) / period_s) + 1)
        wake_s = min(start_s + k * period_s, end_s)
        await clock.sleep(max(0.0, wake_s - clock.now_s()))
