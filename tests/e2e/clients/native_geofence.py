"""MAVSDK 4.x native (ctypes) asyncio geofence client: the flow of ``classic_geofence.py``.

    python native_geofence.py --url udpin://0.0.0.0:PORT

Uses ``mavsdk.asyncio.plugins.geofence.GeofenceAsync`` (upload_geofence, download_geofence,
clear_geofence) and ``MissionRawAsync.download_geofence``. See :func:`_plans.geofence_flow`.
"""

from __future__ import annotations

import argparse
import asyncio
from types import SimpleNamespace

from _common import Report, first, native_autopilot, run
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
        system = await native_autopilot(sdk, args.url, r, 60)
        home = await first(TelemetryAsync(system).subscribe_home())
        ref = (home.latitude_deg, home.longitude_deg, home.absolute_altitude_m)
        r["home"] = list(ref)
        await geofence_flow(r, GeofenceAsync(system), MissionRawAsync(system), types, ref)
        r.stage("done")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    args = ap.parse_args()
    run(lambda report: asyncio.wait_for(main_flow(args, report), 120), Report())


if __name__ == "__main__":
    main()
