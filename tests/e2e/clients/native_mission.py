"""MAVSDK 4.x native (ctypes) asyncio mission client: the flow of ``classic_mission.py``.

    python native_mission.py --url udpin://0.0.0.0:PORT

The native API runs MAVSDK's C++ core in this process (no mavsdk_server, no gRPC). Its mission
plugin is ``mavsdk.asyncio.plugins.mission.MissionAsync`` (streams are ``subscribe_*``).
"""

from __future__ import annotations

import asyncio

from _common import (
    Report,
    collect,
    first,
    home_reference,
    horizontal,
    native_autopilot,
    native_main,
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
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.mission import MissionAsync, MissionItem, MissionPlan
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    tasks: list[asyncio.Task] = []
    async with Mavsdk(config) as sdk:
        r["mavsdk_version"] = await sdk.version()
        system = await native_autopilot(sdk, args.url, r, 120)
        telemetry = TelemetryAsync(system)
        action = ActionAsync(system)
        mission = MissionAsync(system)
        mission_raw = MissionRawAsync(system)
        try:
            modes: list[str] = []
            r["modes"] = modes
            progress: list[list[int]] = []
            r["progress"] = progress

            async def watch_modes() -> None:
                async for mode in telemetry.subscribe_flight_mode():
                    if not modes or modes[-1] != mode.name:
                        modes.append(mode.name)

            tasks.append(asyncio.ensure_future(watch_modes()))
            ref = await home_reference(telemetry.subscribe_home(), r)

            r.stage("params")
            await action.set_takeoff_altitude(TAKEOFF_ALT_M)
            await action.set_return_to_launch_altitude(RTL_ALT_M)

            r.stage("upload")
            plan = MissionPlan(mission_items(MissionItem, ref))
            await mission.set_return_to_launch_after_mission(True)
            await mission.upload_mission(plan)

            r.stage("download")
            uploaded = [mission_item_dict(i) for i in plan.mission_items]
            downloaded = await mission.download_mission()
            r["download_diff"] = diff(
                uploaded, [mission_item_dict(i) for i in downloaded.mission_items]
            )
            r["download_rtl_after_mission"] = await mission.get_return_to_launch_after_mission()
            raw_items = await mission_raw.download_mission()
            r["raw_commands"] = [raw_dict(i)["command"] for i in raw_items]

            r.stage("arm")
            tasks.append(
                asyncio.ensure_future(
                    collect(
                        mission.subscribe_mission_progress(),
                        progress,
                        lambda p: [p.current, p.total],
                    )
                )
            )
            await action.arm()
            await wait_for(telemetry.subscribe_armed(), bool, 30, "armed")

            r.stage("start")
            await mission.start_mission()
            await wait_for(telemetry.subscribe_in_air(), bool, 60, "in_air True")
            await until(
                lambda: progress and progress[-1][0] >= 1, 60, "mission progress current >= 1"
            )

            r.stage("pause")
            at_pause = list(progress[-1])
            await mission.pause_mission()
            await wait_for(
                telemetry.subscribe_flight_mode(), lambda m: m.name == "HOLD", 30, "HOLD"
            )
            await sim_sleep(PAUSE_S)
            r["pause"] = {
                "progress_at_pause": at_pause,
                "progress_after_hold": list(progress[-1]),
                "mode": (await first(telemetry.subscribe_flight_mode())).name,
                "in_air": await first(telemetry.subscribe_in_air()),
                "finished": await mission.is_mission_finished(),
            }

            r.stage("resume")
            await mission.start_mission()
            await until(
                lambda: progress and progress[-1][0] == progress[-1][1] > 0,
                90,
                "mission progress current == total",
            )

            r.stage("rtl_landing")
            await wait_for(telemetry.subscribe_in_air(), lambda a: not a, 90, "in_air False")
            await wait_for(telemetry.subscribe_armed(), lambda a: not a, 60, "auto-disarm")
            q = await first(telemetry.subscribe_position())
            n, e, _ = ned_of(q.latitude_deg, q.longitude_deg, q.absolute_altitude_m, ref)
            r["final"] = {
                "in_air": await first(telemetry.subscribe_in_air()),
                "armed": await first(telemetry.subscribe_armed()),
                "is_mission_finished": await mission.is_mission_finished(),
                "horizontal_from_home_m": horizontal(n, e),
            }

            r.stage("clear")
            r["progress"] = list(progress)  # a clear legitimately resets progress to 0
            await mission.clear_mission()
            r["items_after_clear"] = len((await mission.download_mission()).mission_items)
            r.stage("done")
        finally:
            for task in tasks:
                task.cancel()


def main() -> None:
    native_main(fly, 960)


if __name__ == "__main__":
    main()
