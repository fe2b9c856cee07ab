"""A user's companion program, as a scenario runs it: take off, fly to a point, land.

Plain MAVSDK-Python (classic API). Everything it needs comes from the SWARMSITL_* variables
(``companion.scenario_env``); waits are simulated seconds (``companion.clock``). Its args
(SWARMSITL_PARAMS): ``altitude_m``, ``offset_enu_m`` (where to fly, relative to its start),
``hover_s``, ``break_after`` (``"takeoff"``: raise there, to test that a broken companion is
caught).
"""

from __future__ import annotations

import asyncio
import math
import os
import sys

import pymap3d

from companion import clock
from companion.scenario_env import ScenarioEnv


async def until(stream, predicate, timeout_s: float, what: str):
    """First item of ``stream`` satisfying ``predicate`` within ``timeout_s`` simulated s."""

    async def scan():
        async for item in stream:
            if predicate(item):
                return item
        raise RuntimeError(f"stream ended waiting for {what}")

    start = clock.now_s()
    task = asyncio.ensure_future(scan())
    while not task.done():
        if clock.now_s() - start > timeout_s:
            task.cancel()
            raise TimeoutError(f"no {what} within {timeout_s:g} simulated s")
        await asyncio.sleep(0.01)
    return task.result()


async def fly(env: ScenarioEnv) -> None:
    from mavsdk_grpc import System

    args = env.params or {}
    altitude = float(args.get("altitude_m", 5.0))
    east, north = (float(v) for v in args.get("offset_enu_m", (0.0, 0.0)))
    drone = System(port=env.grpc_port)
    try:
        await drone.connect(system_address=env.mavlink_url)
        await until(drone.core.connection_state(), lambda s: s.is_connected, 60, "connection")
        await until(
            drone.telemetry.health(),
            lambda h: h.is_global_position_ok and h.is_home_position_ok,
            60,
            "a position estimate",
        )
        home = await until(drone.telemetry.position(), lambda p: True, 10, "a position")
        await drone.action.set_takeoff_altitude(altitude)
        await drone.action.arm()
        await drone.action.takeoff()
        await until(
            drone.telemetry.position(),
            lambda p: p.relative_altitude_m > 0.9 * altitude,
            60,
            "the takeoff altitude",
        )
        if args.get("break_after") == "takeoff":
            raise RuntimeError("deliberately broken after takeoff")
        lat, lon, alt = pymap3d.enu2geodetic(
            east, north, altitude, home.latitude_deg, home.longitude_deg, home.absolute_altitude_m
        )
        await drone.action.goto_location(lat, lon, alt, 0.0)

        def arrived(p) -> bool:
            e, n, _ = pymap3d.geodetic2enu(
                p.latitude_deg, p.longitude_deg, p.absolute_altitude_m,
                home.latitude_deg, home.longitude_deg, home.absolute_altitude_m,
            )  # fmt: skip
            return math.hypot(e - east, n - north) < 1.0

        await until(drone.telemetry.position(), arrived, 120, "the goto point")
        await clock.sleep(float(args.get("hover_s", 2.0)))
        await drone.action.land()
        await until(drone.telemetry.armed(), lambda a: not a, 120, "disarm after landing")
        env.write_result({"flown_to_east_m": (east, "m"), "flown_to_north_m": (north, "m")})
    finally:
        drone._stop_mavsdk_server()


if __name__ == "__main__":
    asyncio.run(fly(ScenarioEnv.from_env()))
    sys.stdout.flush()
    os._exit(0)
