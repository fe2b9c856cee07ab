"""Classic MAVSDK-Python (mavsdk_grpc) client: params, version, takeoff, goto, RTL, landing.

    python classic_flight.py --url udpin://0.0.0.0:PORT --grpc-port GRPC

Waits are in wall seconds (generous); settling periods are in simulated seconds, measured with
the vehicle's SYSTEM_TIME (``telemetry.unix_epoch_time()``), so the result does not depend on how
fast the simulation actually runs.
"""

from __future__ import annotations

import asyncio
import math
import statistics

import pymap3d
from _common import (
    ClientError,
    Report,
    classic_main,
    connect_healthy,
    first,
    home_reference,
    horizontal,
    ned_of,
    sim_sleep,
    wait_for,
)

TAKEOFF_ALT_M = 5.0
RTL_ALT_M = 10.0
GOTO_NORTH_M = 20.0


async def positions(drone, count: int):
    """The next ``count`` position samples."""
    out = []
    async for p in drone.telemetry.position():
        out.append(p)
        if len(out) >= count:
            return out
    raise ClientError("position stream ended")


async def watch_modes(drone, modes: list[str]) -> None:
    async for mode in drone.telemetry.flight_mode():
        name = getattr(mode, "name", str(mode))
        if not modes or modes[-1] != name:
            modes.append(name)


async def fly(args, r: Report) -> None:
    from mavsdk_grpc import System
    from mavsdk_grpc.info import InfoError
    from mavsdk_grpc.param import ParamError

    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 120)
        modes: list[str] = []
        r["modes"] = modes
        watcher = asyncio.ensure_future(watch_modes(drone, modes))

        r.stage("version")
        v = None
        for _ in range(40):  # AUTOPILOT_VERSION is requested at connect; allow it to arrive
            try:
                v = await drone.info.get_version()
                break
            except InfoError as exc:
                r["version_error"] = str(exc)
                await asyncio.sleep(0.25)
        if v is None:
            raise ClientError(f"info.get_version() kept failing: {r['version_error']}")
        r["version"] = {
            "major": v.flight_sw_major,
            "minor": v.flight_sw_minor,
            "patch": v.flight_sw_patch,
            "type": str(v.flight_sw_version_type),
        }

        r.stage("params")
        p = drone.param
        f0 = await p.get_param_float("MIS_TAKEOFF_ALT")
        await p.set_param_float("MIS_TAKEOFF_ALT", 7.5)
        f1 = await p.get_param_float("MIS_TAKEOFF_ALT")
        await drone.action.set_takeoff_altitude(TAKEOFF_ALT_M)
        f2 = await p.get_param_float("MIS_TAKEOFF_ALT")
        f3 = await drone.action.get_takeoff_altitude()
        i0 = await p.get_param_int("NAV_RCL_ACT")
        i_new = 3 if i0 != 3 else 1
        await p.set_param_int("NAV_RCL_ACT", i_new)
        i1 = await p.get_param_int("NAV_RCL_ACT")
        await p.set_param_int("NAV_RCL_ACT", i0)
        i2 = await p.get_param_int("NAV_RCL_ACT")
        try:
            await p.get_param_int("MIS_TAKEOFF_ALT")
            wrong_type = "no error"
        except ParamError as exc:
            wrong_type = str(exc._result.result)
        await drone.action.set_return_to_launch_altitude(RTL_ALT_M)
        rtl = await drone.action.get_return_to_launch_altitude()
        r["params"] = {
            "takeoff_alt_default": f0,
            "takeoff_alt_after_set_7_5": f1,
            "takeoff_alt_after_action_set_5": f2,
            "action_get_takeoff_alt": f3,
            "nav_rcl_act_initial": i0,
            "nav_rcl_act_set": i_new,
            "nav_rcl_act_read_back": i1,
            "nav_rcl_act_restored": i2,
            "int_get_of_float_param": wrong_type,
            "rtl_alt": rtl,
        }

        ref = await home_reference(drone.telemetry.home(), r)

        r.stage("arm")
        await drone.action.arm()
        await wait_for(drone.telemetry.armed(), bool, 30, "armed")

        r.stage("takeoff")
        await drone.action.takeoff()
        await wait_for(
            drone.telemetry.position(),
            lambda q: q.relative_altitude_m >= 0.9 * TAKEOFF_ALT_M,
            60,
            "takeoff altitude",
        )
        await sim_sleep(5.0)
        samples = await positions(drone, 10)
        rel = [q.relative_altitude_m for q in samples]
        r["takeoff"] = {
            "rel_alt_mean_m": statistics.fmean(rel),
            "rel_alt_max_error_m": max(abs(a - TAKEOFF_ALT_M) for a in rel),
            "mode_after_settle": modes[-1] if modes else None,
        }

        r.stage("goto")
        lat, lon, _ = pymap3d.ned2geodetic(GOTO_NORTH_M, 0.0, 0.0, *ref)
        alt = ref[2] + TAKEOFF_ALT_M
        target = (float(lat), float(lon), alt)

        def dist(q) -> float:
            n, e, d = ned_of(q.latitude_deg, q.longitude_deg, q.absolute_altitude_m, target)
            return math.sqrt(n * n + e * e + d * d)

        await drone.action.goto_location(target[0], target[1], target[2], 0.0)
        await wait_for(drone.telemetry.position(), lambda q: dist(q) < 1.0, 90, "goto arrival")
        await sim_sleep(3.0)
        samples = await positions(drone, 10)
        r["goto"] = {
            "target": list(target),
            "distance_m": max(dist(q) for q in samples),
            "mode_at_target": modes[-1] if modes else None,
        }

        r.stage("rtl")
        await drone.action.return_to_launch()
        await wait_for(drone.telemetry.in_air(), lambda a: not a, 150, "landed (in_air False)")
        q = (await positions(drone, 1))[0]
        n, e, _ = ned_of(q.latitude_deg, q.longitude_deg, q.absolute_altitude_m, ref)
        r["landing"] = {
            "horizontal_from_home_m": horizontal(n, e),
            "rel_alt_m": q.relative_altitude_m,
        }
        r.stage("disarm")
        await wait_for(drone.telemetry.armed(), lambda a: not a, 60, "auto-disarm")
        r["final"] = {
            "in_air": await first(drone.telemetry.in_air()),
            "armed": await first(drone.telemetry.armed()),
        }
        watcher.cancel()
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def main() -> None:
    classic_main(fly)


if __name__ == "__main__":
    main()
