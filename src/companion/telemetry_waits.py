"""Waiting on MAVSDK telemetry streams, bounded in simulated time.

Shared by the companion scripts (``demo_flight``, ``coverage``): the first item of a stream,
and the first item satisfying a predicate within a limit measured on the vehicle's own clock
(:class:`~companion.vehicle_clock.VehicleClock`) once it runs, else in wall time scaled by the
nominal simulation speed (:func:`companion.clock.speed_factor`).
"""

from __future__ import annotations

import asyncio
from typing import Any

from companion import clock
from companion.vehicle_clock import VehicleClock


class FlightError(RuntimeError):
    """The vehicle did not do what was asked in time."""


async def first(stream: Any) -> Any:
    """The first item of a telemetry stream (``FlightError`` if it ends first)."""
    async for item in stream:
        return item
    raise FlightError("telemetry stream ended")


async def wait_for(
    stream: Any, predicate: Any, timeout_s: float, what: str, vehicle: VehicleClock | None = None
) -> Any:
    """Wait until an item of ``stream`` satisfies ``predicate``, for ``timeout_s`` simulated s.

    With a running ``vehicle`` clock the limit is measured on the vehicle's clock (plus a generous
    wall-clock bound in case telemetry stops); without one (before the first timestamp) it is wall
    time scaled by the nominal simulation speed.
    """

    async def scan() -> Any:
        async for item in stream:
            if predicate(item):
                return item
        raise FlightError(f"telemetry stream ended while waiting for {what}")

    if vehicle is None or not vehicle.started:
        try:
            return await asyncio.wait_for(scan(), timeout_s / clock.speed_factor())
        except TimeoutError as exc:
            raise FlightError(f"timed out after {timeout_s:.0f} s waiting for {what}") from exc
    found = asyncio.create_task(scan())
    limit = asyncio.create_task(vehicle.sleep(timeout_s, 30.0 + 2.0 * timeout_s))
    try:
        await asyncio.wait({found, limit}, return_when=asyncio.FIRST_COMPLETED)
        if found.done():
            return found.result()
        if limit.exception() is not None:
            raise FlightError(f"{limit.exception()} while waiting for {what}")
        raise FlightError(f"timed out after {timeout_s:.0f} s (vehicle time) waiting for {what}")
    finally:
        found.cancel()
        limit.cancel()


async def wait_position_ok(
    drone: Any, vehicle: VehicleClock | None, timeout_s: float = 60.0
) -> Any:
    """Wait until the vehicle has a global position and a home (what a mission or goto needs)."""
    return await wait_for(
        drone.telemetry.health(),
        lambda h: h.is_global_position_ok and h.is_home_position_ok,
        timeout_s,
        "global position and home",
        vehicle,
    )


async def connect(drone: Any, url: str, grpc_port: int, timeout_wall_s: float = 60.0) -> None:
    """``drone.connect(url)`` and wait for the vehicle, each within ``timeout_wall_s``.

    mavsdk_grpc waits for its mavsdk_server without a limit: a server that cannot start (its
    gRPC port taken) would hang the program instead of failing it.
    """
    try:
        await asyncio.wait_for(drone.connect(system_address=url), timeout_wall_s)
    except TimeoutError as exc:
        raise FlightError(
            f"mavsdk_server on gRPC port {grpc_port} did not answer within {timeout_wall_s:g} s"
        ) from exc
    await wait_for(
        drone.core.connection_state(), lambda s: s.is_connected, timeout_wall_s, "connection"
    )
