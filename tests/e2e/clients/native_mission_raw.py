"""MAVSDK 4.x native (ctypes) asyncio mission_raw client: the flow of ``classic_mission_raw.py``.

    python native_mission_raw.py --url udpin://0.0.0.0:PORT

Uses ``mavsdk.asyncio.plugins.mission_raw.MissionRawAsync`` (same call names as the classic
plugin, ``MissionRawError.result`` a ``MissionRawResult`` IntEnum). See
:func:`_plans.raw_plans_flow`.
"""

from __future__ import annotations

from _common import Report, home_reference, native_autopilot, native_main
from _plans import raw_plans_flow


async def main_flow(args, r: Report) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.mission_raw import MissionItem, MissionRawAsync, MissionRawError
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        r["mavsdk_version"] = await sdk.version()
        system = await native_autopilot(sdk, args.url, r, 120)
        ref = await home_reference(TelemetryAsync(system).subscribe_home(), r)
        await raw_plans_flow(r, MissionRawAsync(system), MissionItem, MissionRawError, ref)
        r.stage("done")


def main() -> None:
    native_main(main_flow, 480)


if __name__ == "__main__":
    main()
