"""MAVSDK 4.x native (ctypes) asyncio geofence client: the flow of ``classic_geofence.py``.

    python native_geofence.py --url udpin://0.0.0.0:PORT

Uses ``mavsdk.asyncio.plugins.geofence.GeofenceAsync`` (upload_geofence, download_geofence,
clear_geofence) and ``MissionRawAsync.download_geofence``. See :func:`_plans.geofence_flow`.
"""

from __future__ import annotations

from types import SimpleNamespace

from _common import Report, home_reference, native_autopilot, native_main
from _plans import geofence_flow


async def main_flow(args, r: Report) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.geofence import (
        Circle,
        FenceType,
        GeofenceAsync,
        GeofenceData,
        Point,
        Polygon,
    )
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

    types = SimpleNamespace(
        Point=Point, Polygon=Polygon, Circle=Circle, GeofenceData=GeofenceData, FenceType=FenceType
    )
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        r["mavsdk_version"] = await sdk.version()
        system = await native_autopilot(sdk, args.url, r, 120)
        ref = await home_reference(TelemetryAsync(system).subscribe_home(), r)
        await geofence_flow(r, GeofenceAsync(system), MissionRawAsync(system), types, ref)
        r.stage("done")


def main() -> None:
    native_main(main_flow, 480)


if __name__ == "__main__":
    main()
