"""How a companion program's flight ends: its result first, whatever it left running."""

from __future__ import annotations

import asyncio
import signal
import subprocess
import sys
import textwrap

import pytest

from companion.scripts.program import run_flight

pytestmark = pytest.mark.process


def test_run_flight_returns_the_flights_result_and_cancels_what_it_left_running() -> None:
    ended: list[str] = []

    async def stream() -> None:
        try:
            await asyncio.sleep(3600)
        finally:
            ended.append("stream")

    tasks = []

    async def flight() -> int:
        tasks.append(asyncio.create_task(stream()))
        await asyncio.sleep(0)
        return 7

    assert run_flight(flight()) == 7
    assert ended == ["stream"]


def test_run_flight_returns_although_a_leftover_task_will_not_end() -> None:
    """A task that swallows its cancellation would hold ``asyncio.run`` up for good."""
    cancelled = []

    async def stubborn() -> None:
        while True:
            try:
                await asyncio.sleep(3600)
            except asyncio.CancelledError:
                cancelled.append(True)

    tasks = []

    async def flight() -> str:
        tasks.append(asyncio.create_task(stubborn()))
        await asyncio.sleep(0)
        return "landed"

    assert run_flight(flight(), teardown_wall_s=0.05) == "landed"
    assert cancelled == [True]


def test_run_flight_passes_the_flights_failure_on() -> None:
    async def flight() -> None:
        raise RuntimeError("no GPS")

    with pytest.raises(RuntimeError, match="no GPS"):
        run_flight(flight())


def test_a_program_stopped_by_the_runner_prints_where_it_stood() -> None:
    """SIGTERM (the run ended first): the stacks go to the log, then the program ends."""
    code = textwrap.dedent(
        """
        import sys, time
        from companion.scripts.program import finish

        def waiting_forever(env):
            print("ready", flush=True)
            time.sleep(3600)

        finish(waiting_forever, lambda: None, print)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGTERM
    assert "in waiting_forever" in err
