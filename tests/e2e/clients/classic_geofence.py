"""Classic MAVSDK-Python (mavsdk_grpc) geofence client, as MAVSDK's ``geofence.py`` example.

    python classic_geofence.py --url udpin://0.0.0.0:PORT --grpc-port GRPC

Uploads GeofenceData (an inclusion polygon and an exclusion circle), reads it back both raw
(``mission_raw.download_geofence``, mission_type 1) and through ``geofence.download_geofence``,
clears it and reads both again. See :func:`_plans.geofence_flow`.
"""

from __future__ import annotations

from types import SimpleNamespace

from _common import Report, classic_main, connect_healthy, home_reference
from _plans import geofence_flow


async def main_flow(args, r: Report) -> None:
    from mavsdk_grpc import System
    from mavsdk_grpc.geofence import Circle, FenceType, GeofenceData, Point, Polygon

    types = SimpleNamespace(
        Point=Point, Polygon=Polygon, Circle=Circle, GeofenceData=GeofenceData, FenceType=FenceType
    )
    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 120)
        ref = await home_reference(drone.telemetry.home(), r)
        await geofence_flow(r, drone.geofence, drone.mission_raw, types, ref)
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def main() -> None:
    classic_main(main_flow)


if __name__ == "__main__":
    main()
