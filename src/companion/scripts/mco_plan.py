"""MCO Plan companion (seed 004): plan the fleet's coverage, fly this vehicle's task as a mission.

Every vehicle of the role computes the same plan (:mod:`companion.planning.mco.plan`: grid from
the camera footprint, MCO partition or a baseline, roles, tours, the English auction over the
fleet's traits) from the run's world, the role's ``args``, the fleet description and the seed,
and flies the task the auction gave it: its sub-area's tour out of the take-off point and back,
uploaded as one MAVSDK mission at the survey height (plus ``altitude_step_m`` per role index),
then lands over its own home. Writes ``result.json``: its role, sub-area, waypoints, planned path
and flight time, the plan's heterogeneity, the distance it flew and the battery left at landing
(``telemetry.battery().remaining_percent``, what a ground station reads).

It is driven by the ``SWARMSITL_*`` variables ``swarmsitl run`` sets (docs/scenarios.md):

    python -m companion.scripts.mco_plan --world src/worlds/examples/mco_urban.yaml
    python -m companion.scripts.mco_plan --params '{"planner": "mco_zigzag"}' --role-count 4

Parameters (``SWARMSITL_PARAMS``, the scenario's ``args``): ``McoParams`` and docs/seed004.md.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import pymap3d

from companion.mission_items import waypoint_item
from companion.planning.mco.plan import McoParams
from companion.planning.mco.role import (
    TAKEOFF_M,
    departure_hold_s,
    home_height_m,
    mco_params,
    own_flight_time_s,
    plan_for,
    survey_height_m,
)
from companion.planning.mco.tours import straight_legs
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import (
    finish,
    parser,
    return_after_failure,
    run_flight,
    scenario_env,
)
from companion.swarm.mco import task_metrics
from companion.telemetry_waits import FlightError, connect, first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock

PARAMS = McoParams
"""The dataclass of this program's ``args`` (checked when ``swarmsitl run`` loads a scenario)."""
DEFAULT_ORIGIN = (47.397742, 8.545594, 488.0)
"""World origin if none is given (swarmsitl's default), lat, lon (deg), AMSL (m)."""
LAND_ACCURACY_M = 0.5
"""Horizontal distance from home within which the vehicle starts its descent, m."""
ACCEPTANCE_M = 3.0
"""Acceptance radius of the mission's waypoints, m (fly-through)."""


def _log(name: str, **data: Any) -> None:
    print(f"[mco_plan] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


async def fly(env: ScenarioEnv, params: McoParams) -> dict[str, tuple[Any, str]]:
    """Plan, fly this vehicle's task, land; returns the metrics for ``result.json``."""
    from mavsdk_grpc import System
    from mavsdk_grpc.mission import MissionItem, MissionPlan

    plan = plan_for(env, params)  # before connecting: a plan that cannot be made fails at once
    task = plan.task_of(env.vehicle)
    origin = env.origin or DEFAULT_ORIGIN
    altitude = survey_height_m(params, env.role_index)
    clock = VehicleClock()
    battery = [math.nan]
    distance = [0.0]
    drone = System(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    flying = False

    async def attitudes() -> None:
        async for q in drone.telemetry.attitude_quaternion():
            clock.feed(q.timestamp_us)

    async def batteries() -> None:
        async for b in drone.telemetry.battery():
            battery[0] = float(b.remaining_percent)

    async def odometry() -> None:
        last = None
        async for p in drone.telemetry.position():
            here = np.array(pymap3d.geodetic2enu(p.latitude_deg, p.longitude_deg,
                                                 p.absolute_altitude_m, *origin))  # fmt: skip
            if last is not None and flying:
                distance[0] += float(np.linalg.norm(here - last))
            last = here

    try:
        _log("connecting", url=env.mavlink_url, grpc_port=env.grpc_port)
        await connect(drone, env.mavlink_url, env.grpc_port)
        tasks.append(asyncio.create_task(attitudes()))
        await clock.wait_started(60.0)
        tasks += [asyncio.create_task(batteries()), asyncio.create_task(odometry())]
        await wait_position_ok(drone, clock)
        top_speed = await drone.param.get_param_float("MPC_XY_VEL_MAX")
        speed = min(params.speed_m_s, top_speed)
        await drone.param.set_param_float("MPC_XY_CRUISE", speed)
        home = await first(drone.telemetry.home())
        _log("planned", role=str(task.role), sub_area=task.sub_area,
             waypoints=len(task.waypoints_xy_m), path_m=round(task.path_length_m, 1),
             flight_time_s=round(task.flight_time_s, 1))  # fmt: skip
        home_enu = pymap3d.geodetic2enu(home.latitude_deg, home.longitude_deg,
                                        home.absolute_altitude_m, *origin)[:2]  # fmt: skip
        tour = np.vstack([home_enu, task.waypoints_xy_m, home_enu])
        corners = straight_legs(tour)[1:]  # a mission item where the path turns, then home
        takeoff_m = min(altitude, TAKEOFF_M)
        home_m = home_height_m(params, env.role_index)
        # Up to the survey height over its own home first, then hold there until the vehicles
        # flying higher have climbed past (departure_hold_s).
        climb_m_s = await drone.param.get_param_float("MPC_Z_V_AUTO_UP")
        hold_s = departure_hold_s(params, env.role_index, env.role_count, climb_m_s)
        items = [
            waypoint_item(
                MissionItem,
                home.latitude_deg,
                home.longitude_deg,
                altitude,
                speed,
                ACCEPTANCE_M,
                hold_s,
            )
        ]
        for x, y in corners[:-1]:
            lat, lon, _ = pymap3d.enu2geodetic(float(x), float(y), 0.0, *origin)
            items.append(waypoint_item(MissionItem, lat, lon, altitude, speed, ACCEPTANCE_M))
        # the tour ends over the take-off point: back over its own home, down on the way to a
        # height of its own (a vertical descent from the survey height is a minute more)
        items.append(
            waypoint_item(
                MissionItem, home.latitude_deg, home.longitude_deg, home_m, speed, ACCEPTANCE_M
            )
        )
        await drone.mission.set_return_to_launch_after_mission(False)
        await drone.mission.upload_mission(MissionPlan(items))
        await drone.action.set_takeoff_altitude(takeoff_m)
        await drone.action.set_return_to_launch_altitude(altitude)
        await drone.action.arm()
        flying = True
        armed_at = clock.now_s
        await drone.action.takeoff()
        climb_s = takeoff_m / params.climb_m_s
        await wait_for(
            drone.telemetry.position(), lambda p: p.relative_altitude_m >= 0.9 * takeoff_m,
            climb_s + 60.0, "take-off altitude", clock,
        )  # fmt: skip
        await drone.mission.start_mission()
        _log("mission_started", vehicle_time_s=clock.now_s)
        give_up_s = clock.now_s + 60.0 + 3.0 * task.flight_time_s
        async for m in drone.mission.mission_progress():
            if m.total > 0 and m.current >= m.total:
                break
            if clock.now_s > give_up_s:
                raise FlightError(f"the mission did not end by {give_up_s:.0f} s (vehicle time)")
        _log("mission_done", vehicle_time_s=clock.now_s)
        alt_amsl = home.absolute_altitude_m + home_m
        await drone.action.goto_location(home.latitude_deg, home.longitude_deg, alt_amsl, math.nan)

        def over_home(p: Any) -> bool:
            n, e, _ = pymap3d.geodetic2ned(p.latitude_deg, p.longitude_deg, 0.0,
                                           home.latitude_deg, home.longitude_deg, 0.0)  # fmt: skip
            return math.hypot(n, e) < LAND_ACCURACY_M

        await wait_for(drone.telemetry.position(), over_home, 60.0, "over home", clock)
        await drone.action.land()
        await wait_for(drone.telemetry.in_air(), lambda a: not a, altitude + 120.0, "landing",
                       clock)  # fmt: skip
        await wait_for(drone.telemetry.armed(), lambda a: not a, 30.0, "auto-disarm", clock)
        flying = False
        landed_s = clock.now_s
        await asyncio.sleep(0.2)  # one more battery report after the landing
        _log("landed", vehicle_time_s=landed_s, battery_pct=battery[0])
    except BaseException:
        if flying:
            await return_after_failure(drone, "mco_plan")
        raise
    finally:
        for t in tasks:
            t.cancel()
        drone._stop_mavsdk_server()
    return task_metrics(plan, task, own_flight_time_s(env)) | {
        "battery_remaining": (round(battery[0], 2), "%"),
        "distance_flown_m": (round(distance[0], 1), "m"),
        "mission_time": (round(landed_s - armed_at, 2), "s"),
    }


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> Any:
    """This role behind the swarm-scale engine's kinematic adapter (``companion.swarm.mco``)."""
    from companion.swarm.mco import McoProgram

    return McoProgram(env, vehicle, node)


def main(argv: list[str] | None = None) -> None:
    """Read the environment and options, fly, write result.json; exit 0, or 1 on a failure."""
    ap = parser(__doc__, "src/worlds/examples/mco_urban.yaml", '{"planner": "mco_zigzag"}')
    args = ap.parse_args(argv)

    def fly_with_params(env: ScenarioEnv) -> Mapping[str, tuple[Any, str]]:
        return run_flight(fly(env, mco_params(env)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
