"""Helpers shared by the e2e client scripts (each script runs in its own process).

A client prints exactly one JSON line on stdout (``{"ok": ..., "stage": ..., ...}``) and leaves
with ``os._exit`` so that no stray thread (mavsdk_grpc's log thread) can keep it alive.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import sys
import traceback

import pymap3d


class ClientError(RuntimeError):
    """The vehicle did not do what was asked within the (wall-clock) time limit."""


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


async def wait_for(stream, predicate, timeout_s: float, what: str):
    """First item of ``stream`` satisfying ``predicate``, within ``timeout_s`` wall seconds."""

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

    try:
        return await asyncio.wait_for(scan(), timeout_s)
    except TimeoutError as exc:
        raise ClientError(f"timed out after {timeout_s:.0f} s (wall) waiting for {what}") from exc


async def until(predicate, timeout_s: float, what: str) -> None:
    """Poll ``predicate()`` every 50 ms until it is true, within ``timeout_s`` wall seconds."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while not predicate():
        if loop.time() > deadline:
            raise ClientError(f"timed out after {timeout_s:.0f} s (wall) waiting for {what}")
        await asyncio.sleep(0.05)


async def collect(stream, out: list, convert=lambda item: item) -> None:
    """Append every item of ``stream`` (converted) to ``out``; run it as a task."""
    async for item in stream:
        out.append(convert(item))


async def sim_sleep(epoch_stream, seconds: float) -> None:
    """Sleep ``seconds`` of simulated time.

    ``epoch_stream()`` opens a stream of the vehicle's SYSTEM_TIME in microseconds (classic
    ``telemetry.unix_epoch_time``, native ``telemetry.subscribe_unix_epoch_time``; 1 Hz).
    """
    t0 = await asyncio.wait_for(first(epoch_stream()), 30)
    await wait_for(
        epoch_stream(),
        lambda t: t >= t0 + seconds * 1e6,
        30 + 10 * seconds,
        f"{seconds} simulated seconds",
    )


async def connect_healthy(drone, url: str, report, timeout_s: float) -> None:
    """Connect, then wait until MAVSDK reports global position and home OK (stages recorded)."""
    report.stage("connect")
    await drone.connect(system_address=url)
    await wait_for(drone.core.connection_state(), lambda s: s.is_connected, timeout_s, "connection")
    report.stage("health")
    await wait_for(
        drone.telemetry.health(),
        lambda h: h.is_global_position_ok and h.is_home_position_ok,
        timeout_s,
        "global position and home",
    )


async def native_autopilot(sdk, url: str, report, timeout_s: float):
    """4.x native API: connect, wait for the autopilot and for global position and home OK."""
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    report.stage("connect")
    await sdk.add_any_connection(url)
    system = await sdk.first_autopilot(timeout_s=timeout_s)
    if system is None:
        raise ClientError(f"no autopilot appeared within {timeout_s:.0f} s")
    report.stage("health")
    await wait_for(
        TelemetryAsync(system).subscribe_health(),
        lambda h: h.is_global_position_ok and h.is_home_position_ok,
        timeout_s,
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


def native_main(flow, timeout_s: float) -> None:
    """A native-API client's command line (``--url``), then :func:`run` of ``flow(args,
    report)`` bounded by ``timeout_s`` wall seconds."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    args = ap.parse_args()
    run(lambda report: asyncio.wait_for(flow(args, report), timeout_s), Report())
