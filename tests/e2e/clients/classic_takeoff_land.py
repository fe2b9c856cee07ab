"""Classic MAVSDK-Python client: arm, take off, land, disarm (any connection URL, e.g. serial).

    python classic_takeoff_land.py --url serial:///RUN/vehicle1.serial:921600 --grpc-port GRPC

Reports the relative altitude reached and whether the vehicle landed and disarmed by itself.
"""

from __future__ import annotations

from _common import Report, classic_main, connect_healthy, wait_for


async def fly(args, r: Report) -> None:
    from mavsdk_grpc import System

    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 90)
        r.stage("arm")
        await drone.action.set_takeoff_altitude(args.alt)
        await drone.action.arm()
        await wait_for(drone.telemetry.armed(), bool, 60, "armed")
        r.stage("takeoff")
        await drone.action.takeoff()
        reached = await wait_for(
            drone.telemetry.position(),
            lambda p: p.relative_altitude_m >= 0.9 * args.alt,
            120,
            "90 % of the takeoff altitude",
        )
        r["rel_alt_reached_m"] = reached.relative_altitude_m
        r.stage("land")
        await drone.action.land()
        await wait_for(drone.telemetry.in_air(), lambda a: not a, 120, "on the ground")
        await wait_for(drone.telemetry.armed(), lambda a: not a, 60, "disarmed after landing")
        r["landed"] = True
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def _options(ap) -> None:
    ap.add_argument("--alt", type=float, default=5.0)


def main() -> None:
    classic_main(fly, _options)


if __name__ == "__main__":
    main()
