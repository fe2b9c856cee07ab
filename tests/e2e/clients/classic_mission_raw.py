"""Classic MAVSDK-Python (mavsdk_grpc) mission_raw client: mission, geofence and rally items.

    python classic_mission_raw.py --url udpin://0.0.0.0:PORT --grpc-port GRPC

Uploads a raw mission (MISSION_ITEM_INT fields as they go on the wire), a geofence (inclusion
polygon + exclusion circle, mission_type 1) and rally points (mission_type 2); downloads each and
compares field by field; tries missions PX4 refuses (unsupported frame, outside the fence, inside
the exclusion circle) and records MAVSDK's result; finally clears the mission. See
:func:`_plans.raw_plans_flow`.
"""

from __future__ import annotations

from _common import Report, classic_main, connect_healthy, home_reference
from _plans import raw_plans_flow


async def main_flow(args, r: Report) -> None:
    from mavsdk_grpc import System
    from mavsdk_grpc.mission_raw import MissionItem, MissionRawError

    drone = System(port=args.grpc_port)
    try:
        await connect_healthy(drone, args.url, r, 120)
        ref = await home_reference(drone.telemetry.home(), r)
        await raw_plans_flow(r, drone.mission_raw, MissionItem, MissionRawError, ref)
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def main() -> None:
    classic_main(main_flow)


if __name__ == "__main__":
    main()
