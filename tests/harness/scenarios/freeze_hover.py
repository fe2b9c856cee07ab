"""A plain MAVSDK-Python companion (no swarmsitl import): take off, hover until told, land.

The lockstep test freezes it while it hovers. It tells the test where it is through files in
SWARMSITL_OUT: ``hovering`` (its pid, once at altitude), and waits for ``release`` there.
"""

import asyncio
import logging
import os
import sys
import traceback
from pathlib import Path

from mavsdk_grpc import System

OUT = Path(os.environ["SWARMSITL_OUT"])


async def first(stream, condition):
    async for item in stream:
        if condition(item):
            return item
    raise RuntimeError("stream ended")


async def main() -> None:
    drone = System(port=int(os.environ["SWARMSITL_GRPC_PORT"]))
    await drone.connect(system_address=os.environ["SWARMSITL_MAVLINK_URL"])
    await first(drone.core.connection_state(), lambda s: s.is_connected)
    await first(drone.telemetry.health(), lambda h: h.is_global_position_ok)
    await drone.action.set_takeoff_altitude(5.0)
    await drone.action.arm()
    await drone.action.takeoff()
    await first(drone.telemetry.position(), lambda p: p.relative_altitude_m > 4.5)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "hovering").write_text(str(os.getpid()))
    while not (OUT / "release").exists():
        await asyncio.sleep(0.02)  # wall time: this program knows nothing of the simulation
    await drone.action.land()
    await first(drone.telemetry.armed(), lambda armed: not armed)


if __name__ == "__main__":
    # mavsdk_server's own lines (a heartbeat timeout, a reconnection) go to companion.log.
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        asyncio.run(main())
    except Exception:
        traceback.print_exc()
        sys.stdout.flush()
        os._exit(1)
    os._exit(0)
