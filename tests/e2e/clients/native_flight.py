"""MAVSDK 4.x native (ctypes) asyncio client: takeoff and land.

    python native_flight.py --url udpin://0.0.0.0:PORT

The native API runs MAVSDK's C++ core in this process (no mavsdk_server, no gRPC).
"""

from __future__ import annotations

from _common import ClientError, Report, first, native_main, wait_for, within

TAKEOFF_ALT_M = 4.0


async def fly(args, r: Report) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        r["mavsdk_version"] = await sdk.version()
        r.stage("connect")
        await sdk.add_any_connection(args.url)
        system = await within(sdk.first_autopilot(timeout_s=-1), 120, "an autopilot")
        if system is None:
            raise ClientError("MAVSDK was destroyed while waiting for an autopilot")
        r["sysid"] = await system.get_system_id()
        r["autopilot_type"] = (await system.autopilot_type()).name
        telemetry = TelemetryAsync(system)
        action = ActionAsync(system)
        param = ParamAsync(system)

        r.stage("health")
        await wait_for(
            telemetry.subscribe_health(),
            lambda h: h.is_global_position_ok and h.is_home_position_ok,
            120,
            "global position and home",
        )
        r.stage("params")
        await action.set_takeoff_altitude(TAKEOFF_ALT_M)
        r["takeoff_alt_param"] = await param.get_param_float("MIS_TAKEOFF_ALT")

        r.stage("arm")
        await action.arm()
        await wait_for(telemetry.subscribe_armed(), bool, 30, "armed")
        r.stage("takeoff")
        await action.takeoff()
        reached = await wait_for(
            telemetry.subscribe_position(),
            lambda p: p.relative_altitude_m >= 0.9 * TAKEOFF_ALT_M,
            60,
            "takeoff altitude",
        )
        r["rel_alt_reached_m"] = reached.relative_altitude_m
        await wait_for(telemetry.subscribe_in_air(), bool, 30, "in_air True")
        r["in_air_after_takeoff"] = True

        r.stage("land")
        await action.land()
        await wait_for(telemetry.subscribe_in_air(), lambda a: not a, 120, "in_air False")
        await wait_for(telemetry.subscribe_armed(), lambda a: not a, 60, "disarmed")
        r["final"] = {
            "in_air": await first(telemetry.subscribe_in_air()),
            "armed": await first(telemetry.subscribe_armed()),
            "rel_alt_m": (await telemetry.position()).relative_altitude_m,
        }
        r.stage("done")


def main() -> None:
    native_main(fly, 1200)


if __name__ == "__main__":
    main()
