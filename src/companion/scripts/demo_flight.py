"""Demo companion program: take off, hover, go 50 m north, return to launch, land.

Plain MAVSDK-Python (classic asyncio API, ``mavsdk_grpc``) exactly as it would run on the Pi; it
knows nothing of the simulator. It writes a JSON event log (what it commanded and when, and what
it saw) for the harness to merge into the run report.

Hover and settle times are measured on the vehicle's own clock (the ``timestamp_us`` of its
attitude telemetry, see :mod:`companion.vehicle_clock`), so a simulation that runs slower than its
nominal speed still hovers for the full simulated time. Each event carries that vehicle time
(``vehicle_time_s``) as well as the wall time.

    python -m companion.scripts.demo_flight --url udpin://0.0.0.0:14540 --events events.json
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import pymap3d

from companion import clock
from companion.telemetry_waits import first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock


async def fly(args: argparse.Namespace, events: list[dict[str, Any]]) -> None:
    """The flight itself."""
    from mavsdk_grpc import System

    vehicle_clock = VehicleClock()

    def event(name: str, **data: Any) -> None:
        stamp = vehicle_clock.now_s if vehicle_clock.started else None
        events.append({"event": name, "wall_s": time.time(), "vehicle_time_s": stamp, **data})
        print(f"[demo] {name} {json.dumps(data) if data else ''}", flush=True)

    async def timestamps() -> Any:
        async for q in drone.telemetry.attitude_quaternion():
            yield q.timestamp_us

    def wall_limit(vehicle_s: float) -> float:
        """Wall-clock bound for a wait of ``vehicle_s`` simulated seconds (generous)."""
        return 30.0 + 2.0 * vehicle_s / clock.speed_factor()

    drone = System(port=args.grpc_port)
    follower: asyncio.Task | None = None
    try:
        await drone.connect(system_address=args.url)
        await wait_for(drone.core.connection_state(), lambda s: s.is_connected, 60, "connection")
        follower = asyncio.create_task(vehicle_clock.follow(timestamps()))
        await vehicle_clock.wait_started(wall_limit(10.0))
        event("connected")
        await wait_position_ok(drone, vehicle_clock)
        home = await first(drone.telemetry.home())
        event(
            "health_ok",
            home_lat=home.latitude_deg,
            home_lon=home.longitude_deg,
            home_alt_amsl_m=home.absolute_altitude_m,
        )
        cruise = await drone.param.get_param_float("MPC_XY_CRUISE")
        event("parameters", mpc_xy_cruise_m_s=cruise)
        await drone.action.set_takeoff_altitude(args.takeoff_alt)
        await drone.action.set_return_to_launch_altitude(args.rtl_alt)
        await drone.action.arm()
        event("armed")
        await drone.action.takeoff()
        event("takeoff_commanded", altitude_m=args.takeoff_alt)
        await wait_for(
            drone.telemetry.position(),
            lambda p: p.relative_altitude_m >= 0.95 * args.takeoff_alt,
            60,
            "takeoff altitude",
            vehicle_clock,
        )
        event("takeoff_reached")
        await vehicle_clock.sleep(args.hover_s, wall_limit(args.hover_s))
        pos = await first(drone.telemetry.position())
        event("hover_done", relative_alt_m=pos.relative_altitude_m)

        lat, lon, _ = pymap3d.ned2geodetic(
            args.goto_north_m,
            args.goto_east_m,
            0.0,
            home.latitude_deg,
            home.longitude_deg,
            home.absolute_altitude_m,
        )
        alt = home.absolute_altitude_m + args.takeoff_alt
        await drone.action.goto_location(float(lat), float(lon), alt, 0.0)
        event("goto_commanded", lat=float(lat), lon=float(lon), alt_amsl_m=alt)

        def arrived(p: Any) -> bool:
            n, e, d = pymap3d.geodetic2ned(
                p.latitude_deg, p.longitude_deg, p.absolute_altitude_m, lat, lon, alt
            )
            return math.sqrt(n * n + e * e + d * d) < args.arrive_radius_m

        await wait_for(drone.telemetry.position(), arrived, 90, "goto arrival", vehicle_clock)
        event("goto_arrived")
        await vehicle_clock.sleep(args.settle_s, wall_limit(args.settle_s))
        p = await first(drone.telemetry.position())
        n, e, d = pymap3d.geodetic2ned(
            p.latitude_deg, p.longitude_deg, p.absolute_altitude_m, lat, lon, alt
        )
        event("goto_settled", reported_error_m=math.sqrt(n * n + e * e + d * d))
        await drone.action.return_to_launch()
        event("rtl_commanded")
        await wait_for(drone.telemetry.in_air(), lambda a: not a, 180, "landing", vehicle_clock)
        event("landed")
        await wait_for(drone.telemetry.armed(), lambda a: not a, 30, "auto-disarm", vehicle_clock)
        event("disarmed")
    finally:
        if follower is not None:
            follower.cancel()
        # Stop this client's mavsdk_server so it does not keep the UDP port (see module notes).
        drone._stop_mavsdk_server()


def main(argv: list[str] | None = None) -> int:
    """Parse arguments, fly, write the event log; exit 0 on success, 1 on a flight error."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--url", default="udpin://0.0.0.0:14540", help="MAVSDK connection URL")
    ap.add_argument("--grpc-port", type=int, default=50051, help="port of this mavsdk_server")
    ap.add_argument("--takeoff-alt", type=float, default=5.0, help="takeoff altitude, m")
    ap.add_argument("--rtl-alt", type=float, default=10.0, help="RTL return altitude, m")
    ap.add_argument("--hover-s", type=float, default=5.0, help="hover time, simulated s")
    ap.add_argument("--goto-north-m", type=float, default=50.0, help="goto leg north, m")
    ap.add_argument("--goto-east-m", type=float, default=0.0, help="goto leg east, m")
    ap.add_argument("--arrive-radius-m", type=float, default=1.0)
    ap.add_argument("--settle-s", type=float, default=3.0, help="hold at the goal, simulated s")
    ap.add_argument("--events", type=Path, help="write the JSON event log here")
    args = ap.parse_args(argv)
    events: list[dict[str, Any]] = []
    rc = 0
    try:
        asyncio.run(fly(args, events))
    except Exception as exc:  # report any client-side failure in the event log, then exit 1
        events.append({"event": "error", "wall_s": time.time(), "message": repr(exc)})
        print(f"[demo] error: {exc!r}", file=sys.stderr, flush=True)
        rc = 1
    if args.events:
        args.events.write_text(
            json.dumps(
                {"settings": vars(args) | {"events": None}, "events": events}, default=str, indent=1
            )
        )
    sys.stdout.flush()
    sys.stderr.flush()
    # mavsdk_grpc leaves a non-daemon log thread behind; leave without waiting for it.
    os._exit(rc)


if __name__ == "__main__":
    main()
