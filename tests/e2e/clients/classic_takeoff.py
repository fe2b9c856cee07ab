"""Classic MAVSDK-Python client for one vehicle of a swarm: identity, arm, take off [, land].

    python classic_takeoff.py --url udpin://0.0.0.0:PORT --grpc-port GRPC --alt 5
    python classic_takeoff.py --url serial:///RUN/vehicle1.serial:921600 --grpc-port GRPC --land

Reports the system ids seen in HEARTBEATs (mavlink_direct), MAV_SYS_ID, the home position and
the relative altitude reached; with ``--land`` also whether the vehicle landed and disarmed by
itself. Any connection URL MAVSDK takes works (UDP, serial).
"""

from __future__ import annotations

from _common import Report, classic_main, connect_healthy, first, wait_for, within


async def heartbeat_sysids(drone, count: int) -> list[int]:
    """System ids of the next ``count`` HEARTBEATs received by mavsdk_server."""
    ids = []
    async for msg in drone.mavlink_direct.message("HEARTBEAT"):
        ids.append(int(msg.system_id))
        if len(ids) >= count:
            return ids
    return ids


async def fly(args, r: Report) -> None:
    from mavsdk_grpc import System

    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 120)
        r.stage("identity")
        r["heartbeat_sysids"] = await within(heartbeat_sysids(drone, 3), 60, "three HEARTBEATs")
        r["mav_sys_id"] = await drone.param.get_param_int("MAV_SYS_ID")
        home = await first(drone.telemetry.home())
        r["home"] = [home.latitude_deg, home.longitude_deg, home.absolute_altitude_m]

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
        r["in_air"] = await wait_for(drone.telemetry.in_air(), bool, 60, "in_air")
        if args.land:
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
    ap.add_argument("--land", action="store_true", help="land after the take-off, wait disarmed")


def main() -> None:
    classic_main(fly, _options)


if __name__ == "__main__":
    main()
