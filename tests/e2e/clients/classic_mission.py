"""Classic MAVSDK-Python (mavsdk_grpc) mission client, as MAVSDK's ``mission.py`` example.

    python classic_mission.py --url udpin://0.0.0.0:PORT --grpc-port GRPC

Uploads three waypoints around home (one with a speed, one fly-through, one with a loiter time)
with RTL after the mission, downloads and compares them, flies them with one pause/resume, waits
for the RTL landing and auto-disarm, then clears the mission. Waits are in wall seconds;
settling periods in simulated seconds (the vehicle's SYSTEM_TIME).
"""

from __future__ import annotations

import asyncio

from _common import (
    Report,
    classic_main,
    collect,
    connect_healthy,
    first,
    home_reference,
    horizontal,
    ned_of,
    sim_sleep,
    until,
    wait_for,
)
from _plans import diff, mission_item_dict, mission_items, raw_dict

TAKEOFF_ALT_M = 5.0
RTL_ALT_M = 8.0
PAUSE_S = 3.0
"""Simulated seconds the mission stays paused."""


async def fly(args, r: Report) -> None:
    from mavsdk_grpc import System
    from mavsdk_grpc.mission import MissionItem, MissionPlan

    drone = System(port=args.grpc_port)
    tasks: list[asyncio.Task] = []
    try:
        await connect_healthy(drone, args.url, r, 120)
        modes: list[str] = []
        r["modes"] = modes
        progress: list[list[int]] = []
        r["progress"] = progress

        async def watch_modes() -> None:
            async for mode in drone.telemetry.flight_mode():
                if not modes or modes[-1] != mode.name:
                    modes.append(mode.name)

        tasks.append(asyncio.ensure_future(watch_modes()))
        ref = await home_reference(drone.telemetry.home(), r)

        r.stage("params")
        await drone.action.set_takeoff_altitude(TAKEOFF_ALT_M)
        await drone.action.set_return_to_launch_altitude(RTL_ALT_M)

        r.stage("upload")
        plan = MissionPlan(mission_items(MissionItem, ref))
        await drone.mission.set_return_to_launch_after_mission(True)
        await drone.mission.upload_mission(plan)

        r.stage("download")
        uploaded = [mission_item_dict(i) for i in plan.mission_items]
        downloaded = await drone.mission.download_mission()
        got = [mission_item_dict(i) for i in downloaded.mission_items]
        r["download_diff"] = diff(uploaded, got)
        r["download_rtl_after_mission"] = await drone.mission.get_return_to_launch_after_mission()
        raw_items = await drone.mission_raw.download_mission()
        r["raw_commands"] = [raw_dict(i)["command"] for i in raw_items]

        r.stage("arm")
        tasks.append(
            asyncio.ensure_future(
                collect(drone.mission.mission_progress(), progress, lambda p: [p.current, p.total])
            )
        )
        await drone.action.arm()
        await wait_for(drone.telemetry.armed(), bool, 30, "armed")

        r.stage("start")
        await drone.mission.start_mission()
        await wait_for(drone.telemetry.in_air(), bool, 60, "in_air True")
        await until(lambda: progress and progress[-1][0] >= 1, 60, "mission progress current >= 1")

        r.stage("pause")
        at_pause = list(progress[-1])
        await drone.mission.pause_mission()
        await wait_for(drone.telemetry.flight_mode(), lambda m: m.name == "HOLD", 30, "HOLD")
        await sim_sleep(PAUSE_S)
        r["pause"] = {
            "progress_at_pause": at_pause,
            "progress_after_hold": list(progress[-1]),
            "mode": (await first(drone.telemetry.flight_mode())).name,
            "in_air": await first(drone.telemetry.in_air()),
            "finished": await drone.mission.is_mission_finished(),
        }

        r.stage("resume")
        await drone.mission.start_mission()
        await until(
            lambda: progress and progress[-1][0] == progress[-1][1] > 0,
            90,
            "mission progress current == total",
        )

        r.stage("rtl_landing")
        await wait_for(drone.telemetry.in_air(), lambda a: not a, 90, "landed (in_air False)")
        await wait_for(drone.telemetry.armed(), lambda a: not a, 60, "auto-disarm")
        q = await first(drone.telemetry.position())
        n, e, _ = ned_of(q.latitude_deg, q.longitude_deg, q.absolute_altitude_m, ref)
        r["final"] = {
            "in_air": await first(drone.telemetry.in_air()),
            "armed": await first(drone.telemetry.armed()),
            "is_mission_finished": await drone.mission.is_mission_finished(),
            "horizontal_from_home_m": horizontal(n, e),
        }

        r.stage("clear")
        r["progress"] = list(progress)  # a clear legitimately resets progress to 0
        await drone.mission.clear_mission()
        r["items_after_clear"] = len((await drone.mission.download_mission()).mission_items)
        r.stage("done")
    finally:
        for task in tasks:
            task.cancel()
        drone._stop_mavsdk_server()


def main() -> None:
    classic_main(fly)


if __name__ == "__main__":
    main()
