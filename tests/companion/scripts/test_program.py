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


def _stopped_once_ready(code: str) -> str:
    """Run ``code``; once it prints ``ready``, SIGTERM it as the runner does; its stderr.

    The program must die of the signal (exit -15), as before the report was added.
    """
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGTERM
    return err


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
    err = _stopped_once_ready(code)
    assert "in waiting_forever" in err


def test_a_stopped_flight_reports_each_waiting_coroutine() -> None:
    """Thread stacks end in the event loop (``select``); the task stacks say what it awaited."""
    code = textwrap.dedent(
        """
        import asyncio
        from companion.scripts.program import finish, run_flight

        async def wait_for_the_vehicle():
            print("ready", flush=True)
            await asyncio.Event().wait()

        async def flight():
            await asyncio.gather(wait_for_the_vehicle())

        finish(lambda env: run_flight(flight()), lambda: None, print)
        """
    )
    err = _stopped_once_ready(code)
    assert "Current thread" in err  # faulthandler's thread stacks, then each task's
    tasks = err[err.index("Current thread") :]
    assert "Stack for <Task" in tasks
    assert "in wait_for_the_vehicle" in tasks[tasks.index("Stack for <Task") :]


def test_mavsdk_servers_messages_reach_the_companions_log() -> None:
    """mavsdk_grpc hands mavsdk_server's output to the ``mavsdk_server`` logger."""
    code = textwrap.dedent(
        """
        import logging
        from companion.scripts.program import finish

        def fly(env):
            logging.getLogger("mavsdk_server").info("System discovered")
            return {}

        class Env:
            def write_result(self, metrics):
                return "result.json"

        finish(fly, Env, lambda *a, **k: None)
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "[mavsdk_server] INFO System discovered" in done.stderr
