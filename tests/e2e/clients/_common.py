"""Helpers shared by the e2e client scripts (each script runs in its own process).

A client prints exactly one JSON line on stdout (``{"ok": ..., "stage": ..., ...}``) and leaves
with ``os._exit`` so that no stray thread (mavsdk_grpc's log thread) can keep it alive.

Every limit is in simulated seconds, read from the simulation's clock file
(``SWARMSITL_CLOCK_FILE``, which ``e2e_support.start_client`` exports; ``companion.clock``):
:func:`within`, :func:`wait_for`, :func:`until` and :func:`sim_sleep`. A slow machine makes the
simulation slower, never a client late. The wall clock only backs each wait up as its watchdog
(``harness.pytest_plugin.watchdog_wall_s``), for a simulation that stopped advancing.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import math
import os
import sys
import time
import traceback

import pymap3d

from companion import clock
from harness.pytest_plugin import watchdog_wall_s

POLL_WALL_S = 0.05
"""How often a wait looks at the simulation clock, wall seconds."""


class ClientError(RuntimeError):
    """The vehicle did not do what was asked within the (simulated) time limit."""


def sim_now_s() -> float:
    """The simulation's time, s (its clock file; the e2e clients always have one)."""
    if clock.clock_file() is None:
        raise ClientError(
            "SWARMSITL_CLOCK_FILE is not set: e2e clients wait in simulated time "
            "(start them with e2e_support.start_client)"
        )
    return clock.now_s()


class SimTimeout(ClientError):
    """The simulated time limit of a wait passed (:func:`within`)."""


class Report(dict):
    """What the client measured, plus the stage it reached."""

    def stage(self, name: str) -> None:
        self["stage"] = name
        print(f"[client] stage {name}", file=sys.stderr, flush=True)


async def first(stream):
    """First item of an async generator, which is then closed.

    Closing it at once matters for the native 4.x API: an open subscription keeps its plugin
    referenced, and ``Mavsdk`` aborts the process (SIGABRT) if it is destroyed while a plugin
    it handed out is still alive.
    """
    try:
        async for item in stream:
            return item
        raise ClientError("stream ended")
    finally:
        aclose = getattr(stream, "aclose", None)
        if aclose is not None:
            await aclose()


async def home_reference(stream, report) -> tuple[float, float, float]:
    """The first home of ``stream`` as (lat, lon, alt AMSL), also recorded in ``report``."""
    home = await first(stream)
    ref = (home.latitude_deg, home.longitude_deg, home.absolute_altitude_m)
    report["home"] = list(ref)
    return ref


async def within(awaitable, timeout_sim_s: float, what: str):
    """The result of ``awaitable`` within ``timeout_sim_s`` simulated seconds.

    Raises :class:`SimTimeout` when the simulation's clock passed the limit first, and
    :class:`ClientError` when the wall-clock watchdog fired (``watchdog_wall_s``: ten times the
    limit at the nominal speed ``SWARMSITL_SPEED``, at least 120 s): then the simulation stopped
    advancing, which the message says. The awaitable is cancelled on the way out.
    """
    task = asyncio.ensure_future(awaitable)
    start_sim = sim_now_s()
    start_wall = time.monotonic()
    watchdog = watchdog_wall_s(timeout_sim_s, clock.speed_factor())
    try:
        while True:
            # Read before the wait: a result that came in time is never judged late because
            # the simulation ran on while this process was slow to look.
            elapsed = sim_now_s() - start_sim
            done, _ = await asyncio.wait({task}, timeout=POLL_WALL_S)
            if done:
                return task.result()
            if elapsed > timeout_sim_s:
                raise SimTimeout(
                    f"timed out after {timeout_sim_s:g} simulated s waiting for {what}"
                )
            waited = time.monotonic() - start_wall
            if waited > watchdog:
                raise ClientError(
                    f"watchdog, not a timing assertion: no {what} after {waited:.0f} wall s, in "
                    f"which the simulation advanced only {elapsed:.1f} of the "
                    f"{timeout_sim_s:g} simulated s allowed (stopped, or starved of CPU?)"
                )
    finally:
        if not task.done():
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task


async def wait_for(stream, predicate, timeout_sim_s: float, what: str):
    """First item of ``stream`` satisfying ``predicate``, within ``timeout_sim_s`` simulated
    seconds (:func:`within`)."""

    async def scan():
        try:
            async for item in stream:
                if predicate(item):
                    return item
            raise ClientError(f"stream ended while waiting for {what}")
        finally:
            aclose = getattr(stream, "aclose", None)
            if aclose is not None:
                await aclose()  # see first()

    return await within(scan(), timeout_sim_s, what)


async def until(predicate, timeout_sim_s: float, what: str) -> None:
    """Poll ``predicate()`` every 50 wall ms until it is true, within ``timeout_sim_s``
    simulated seconds (:func:`within`)."""

    async def poll():
        while not predicate():
            await asyncio.sleep(POLL_WALL_S)

    await within(poll(), timeout_sim_s, what)


async def sim_sleep(seconds: float) -> None:
    """Sleep ``seconds`` of simulated time (the simulation's clock; a watchdog if it stops)."""
    end = sim_now_s() + seconds
    await until(lambda: sim_now_s() >= end, 2 * seconds + 1, f"{seconds:g} simulated seconds")


async def collect(stream, out: list, convert=lambda item: item) -> None:
    """Append every item of ``stream`` (converted) to ``out``; run it as a task."""
    async for item in stream:
        out.append(convert(item))


async def connect_healthy(drone, url: str, report, timeout_sim_s: float) -> None:
    """Connect, then wait until MAVSDK reports global position and home OK (stages recorded)."""
    report.stage("connect")
    await drone.connect(system_address=url)
    await wait_for(
        drone.core.connection_state(), lambda s: s.is_connected, timeout_sim_s, "connection"
    )
    report.stage("health")
    await wait_for(
        drone.telemetry.health(),
        lambda h: h.is_global_position_ok and h.is_home_position_ok,
        timeout_sim_s,
        "global position and home",
    )


async def native_autopilot(sdk, url: str, report, timeout_sim_s: float):
    """4.x native API: connect, wait for the autopilot and for global position and home OK."""
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    report.stage("connect")
    await sdk.add_any_connection(url)
    system = await within(sdk.first_autopilot(timeout_s=-1), timeout_sim_s, "an autopilot")
    if system is None:
        raise ClientError("MAVSDK was destroyed while waiting for an autopilot")
    report.stage("health")
    await wait_for(
        TelemetryAsync(system).subscribe_health(),
        lambda h: h.is_global_position_ok and h.is_home_position_ok,
        timeout_sim_s,
        "global position and home",
    )
    return system


def ned_of(lat: float, lon: float, alt: float, ref: tuple[float, float, float]):
    """(north, east, down) of a geodetic point relative to ``ref`` (lat, lon, alt AMSL)."""
    n, e, d = pymap3d.geodetic2ned(lat, lon, alt, *ref)
    return float(n), float(e), float(d)


def horizontal(n: float, e: float) -> float:
    return math.hypot(n, e)


def run(main, report: Report) -> None:
    """Run ``main(report)``, print the report as one JSON line, exit hard."""
    rc = 0
    report.setdefault("ok", False)
    try:
        asyncio.run(main(report))
        report["ok"] = True
    except BaseException as exc:  # report everything, including timeouts and KeyboardInterrupt
        report["error"] = f"{type(exc).__name__}: {exc}"
        traceback.print_exc(file=sys.stderr)
        rc = 1
    print(json.dumps(report, default=str), flush=True)
    sys.stderr.flush()
    os._exit(rc)


def classic_main(flow, options=lambda ap: None) -> None:
    """A classic-API client's command line (``--url``, ``--grpc-port``, ``options``), then
    :func:`run` of ``flow(args, report)``."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--grpc-port", type=int, required=True)
    options(ap)
    args = ap.parse_args()
    run(lambda report: flow(args, report), Report())


def native_main(flow, timeout_sim_s: float) -> None:
    """A native-API client's command line (``--url``), then :func:`run` of ``flow(args,
    report)`` bounded by ``timeout_sim_s`` simulated seconds."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    args = ap.parse_args()
    run(lambda report: within(flow(args, report), timeout_sim_s, "the whole flow"), Report())
