"""Zigzag coverage companion: survey this vehicle's part of the world, count the oil spills seen.

The companion of ``swarmsitl demo`` (offshore): K vehicles share the area; each plans its own
strip (:mod:`companion.planning.coverage`, vehicle ``role_index`` of ``role_count``), takes off,
flies its lanes as a MAVSDK mission at ``altitude_m`` above its launch point and back above it
(around obstacles), and lands there before the run's ``duration_s`` ends (or returns to launch
early, at an altitude that clears the solids on the way, if time runs out). Meanwhile it reads
its camera stream
(``video_uri``, MJPEG over HTTP, with OpenCV), pairs each frame with the latest telemetry pose,
finds dark patches on the sea (:mod:`companion.perception.spill_detector`) and counts distinct
spills. With the world's map it also counts the spills (present by then) whose outline met the
camera's footprint along the flown track: what could have been seen. Writes ``result.json``
(``ScenarioEnv.write_result``): spills_seen, spills_in_footprint, distance_flown_m,
coverage_fraction (of its own strip), and exits 0; on a failure it exits 1 with the traceback on
stderr, after asking the vehicle to return to launch if it was flying.

It is driven by the ``SWARMSITL_*`` variables ``swarmsitl run`` sets (docs/scenarios.md) and
knows nothing of the simulator; the options below override them for running it by hand:

    python -m companion.scripts.coverage --url udpin://0.0.0.0:14540 --duration 120
    python -m companion.scripts.coverage --params '{"area_enu_m": [-20, -20, 40, 20]}'

Parameters (``SWARMSITL_PARAMS`` JSON, the scenario's ``args``), all optional: see
``CoverageParams`` and docs/companions.md.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import os
import threading
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d
import shapely

from companion.mission_items import waypoint_item
from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_quaternion
from companion.perception.spill_detector import DetectorConfig, SpillCounter, detect_spills
from companion.perception.stream_reader import PosedStreamReader
from companion.planning.coverage import (
    Router,
    VehiclePlan,
)
from companion.planning.coverage_role import (
    CoverageParams,
    climb_and_landing_s,
    finish_time_s,
    launch_surface_up_m,
    plan,
    return_altitude_m,
    world_spills,
)
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import (
    finish,
    parser,
    return_after_failure,
    run_flight,
    scenario_env,
)
from companion.telemetry_waits import FlightError, connect, first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock

PARAMS = CoverageParams
"""The dataclass of this program's ``args``: ``swarmsitl run`` checks a role's ``args`` with it
when it loads the scenario (``companion.role_params``)."""
LAND_ACCURACY_M = 0.5
"""Horizontal distance from home within which the vehicle starts its descent, m."""
FOOTPRINT_PERIOD_S = 0.5
"""Simulated seconds between two camera footprints of the ground-truth track."""
DEFAULT_ORIGIN = (47.397742, 8.545594, 488.0)
"""World origin if none is given (swarmsitl's default), lat, lon (deg), AMSL (m)."""


def _log(name: str, **data: Any) -> None:
    print(f"[coverage] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


def _load_world(env: ScenarioEnv) -> Any:
    """The run's world (``worlds.World``), or None."""
    if env.world is None:
        return None
    import worlds

    return worlds.build(worlds.load_world(env.world))


@dataclass
class Pose:
    """The latest telemetry: vehicle time, ENU position, FLU -> ENU attitude."""

    time_s: float = math.nan
    position_enu_m: np.ndarray | None = None
    rotation_flu_enu: np.ndarray | None = None


class CameraWatcher(PosedStreamReader):
    """Reads the video stream in a thread; detects and counts spills on frames taken in flight."""

    def __init__(self, uri: str, params: CoverageParams, pose: Pose, lock: threading.Lock) -> None:
        super().__init__(uri, pose, lock, "coverage-camera")
        self.params = params
        self.counter = SpillCounter(merge_radius_m=params.merge_radius_m)
        self.config = DetectorConfig(dark_max=params.dark_max)

    def camera_for(self, width_px: int, height_px: int) -> CameraModel:
        """The down-looking camera of the params, sized to the frames."""
        return CameraModel(
            width_px=width_px,
            height_px=height_px,
            hfov_deg=self.params.hfov_deg,
            pitch_deg=self.params.camera_pitch_deg,
        )

    def use(
        self, rgb: np.ndarray, camera: CameraModel, position: np.ndarray, rotation: Any
    ) -> None:
        """Detect the spills in one frame and count the new ones."""
        detections = detect_spills(rgb, camera, position, rotation, self.config)
        with self.lock:
            new = self.counter.add(detections)
            latest = [s.position_enu_m.round(2).tolist() for s in self.counter.spills[-new:]]
        if new:
            _log("spill_seen", count=self.counter.count, new_at_enu_m=latest)


@dataclass
class Track:
    """What the vehicle flew: distance, and camera footprints with their times."""

    distance_m: float = 0.0
    last_enu_m: np.ndarray | None = None
    footprints: list[tuple[float, shapely.Polygon]] | None = None
    last_footprint_s: float = -math.inf


async def fly(env: ScenarioEnv, params: CoverageParams) -> dict[str, tuple[Any, str]]:
    """The whole flight; returns the metrics for ``result.json``."""
    from mavsdk_grpc import System
    from mavsdk_grpc.mission import MissionItem, MissionPlan

    world = _load_world(env)
    origin = env.origin or DEFAULT_ORIGIN
    vehicle_clock = VehicleClock()
    lock = threading.Lock()
    pose = Pose()
    track = Track(footprints=[])
    surveying = False
    footprint_camera = CameraModel(hfov_deg=params.hfov_deg, pitch_deg=params.camera_pitch_deg)
    watcher = (
        CameraWatcher(env.video_uri, params, pose, lock) if env.video_uri is not None else None
    )
    duration = env.duration_s if env.duration_s is not None else math.inf

    async def attitudes() -> None:
        async for q in drone.telemetry.attitude_quaternion():
            vehicle_clock.feed(q.timestamp_us)
            rotation = rotation_flu_enu_from_quaternion(q.w, q.x, q.y, q.z)
            with lock:
                pose.rotation_flu_enu = rotation

    async def positions() -> None:
        async for p in drone.telemetry.position():
            if not launch_up_m:
                continue  # no height before home is known (the vehicle is still on its pad)
            e, n, _ = pymap3d.geodetic2enu(
                p.latitude_deg, p.longitude_deg, p.absolute_altitude_m, *origin
            )
            # Height from the launch surface and the barometric height above home, not from
            # the GNSS altitude (metres off): launch_surface_up_m.
            u = launch_up_m[0] + p.relative_altitude_m
            here = np.array([e, n, u], dtype=float)
            now = vehicle_clock.now_s if vehicle_clock.started else math.nan
            with lock:
                pose.position_enu_m = here
                pose.time_s = now
                rotation = pose.rotation_flu_enu
            if track.last_enu_m is not None and armed_flag[0]:
                track.distance_m += float(np.linalg.norm(here - track.last_enu_m))
            track.last_enu_m = here
            if (
                surveying
                and rotation is not None
                and now - track.last_footprint_s >= FOOTPRINT_PERIOD_S
            ):
                # The stream's frame size once known (the footprint's aspect ratio).
                camera = watcher.camera if watcher is not None else None
                footprint = (camera or footprint_camera).footprint(here, rotation)
                if footprint is not None:
                    track.footprints.append((now, footprint))
                    track.last_footprint_s = now

    async def armed_state() -> None:
        async for a in drone.telemetry.armed():
            armed_flag[0] = a

    armed_flag = [False]
    launch_up_m: list[float] = []
    """Height of the launch surface, once home is known (until then positions are unknown)."""
    drone = System(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    flying = False
    try:
        _log("connecting", url=env.mavlink_url, grpc_port=env.grpc_port)
        await connect(drone, env.mavlink_url, env.grpc_port)
        tasks.append(asyncio.create_task(attitudes()))
        await vehicle_clock.wait_started(60.0)
        tasks += [asyncio.create_task(positions()), asyncio.create_task(armed_state())]
        _log("connected", vehicle_time_s=vehicle_clock.now_s)
        await wait_position_ok(drone, vehicle_clock)
        # RTL flies home at MPC_XY_CRUISE: the lanes' speed, so the budgeted return holds.
        top_speed = await drone.param.get_param_float("MPC_XY_VEL_MAX")
        if params.speed_m_s > top_speed:
            _log("speed_capped", speed_m_s=top_speed, asked_m_s=params.speed_m_s)
            params = dataclasses.replace(params, speed_m_s=top_speed)
        await drone.param.set_param_float("MPC_XY_CRUISE", params.speed_m_s)
        home = await first(drone.telemetry.home())
        home_enu = np.array(
            pymap3d.geodetic2enu(
                home.latitude_deg, home.longitude_deg, home.absolute_altitude_m, *origin
            ),
            dtype=float,
        )
        home_enu[2] = launch_surface_up_m(world, home_enu)
        launch_up_m.append(float(home_enu[2]))
        now = vehicle_clock.now_s
        shared, params = params, params.own(env.role_index)
        # Take-off lasts until the highest of the role is up (nobody leaves before: below).
        climb_s = climb_and_landing_s(shared.own(env.role_count - 1))[0]
        land_s = climb_and_landing_s(params)[1]
        budget = duration - now - climb_s - land_s - params.reserve_s
        if budget <= 0:
            raise FlightError(
                f"no time to fly: {duration - now:.0f} s left of the run, "
                f"{climb_s + land_s + params.reserve_s:.0f} s needed for take-off and landing"
            )
        path = plan(env, shared, world, home_enu, budget if math.isfinite(budget) else None)
        # The mission ends above home (around obstacles at the flight altitude) and lands there;
        # an early return (time up, failure) is RTL, straight, at an altitude clearing them.
        rtl_alt = return_altitude_m(world, home_enu, path.waypoints_enu_m, params.altitude_m)
        _, rtl_land_s = climb_and_landing_s(params, rtl_alt)
        waypoints = path.waypoints_enu_m
        _log(
            "planned",
            part=f"{env.role_index + 1}/{env.role_count}",
            lanes=len(path.part.lanes),
            waypoints=len(waypoints),
            length_m=round(path.length_m, 1),
            truncated=path.truncated,
            budget_s=round(budget, 1),
            home_enu_m=home_enu.round(2).tolist(),
            return_altitude_m=round(rtl_alt, 1),
        )
        if len(waypoints) == 0:
            raise FlightError(f"the {budget:.0f} s budget leaves no part of the strip to fly")
        items = []
        way_home = np.vstack([path.return_route_enu_m, [[*home_enu[:2], 0.0]]])
        mission_xy = np.vstack([waypoints, way_home])[:, :2]
        for x, y in mission_xy:
            lat, lon, _ = pymap3d.enu2geodetic(x, y, 0.0, *origin)
            # heading left to the autopilot: it faces the lanes, across the image
            items.append(
                waypoint_item(MissionItem, lat, lon, params.altitude_m, params.speed_m_s, 2.0)
            )
        await drone.mission.set_return_to_launch_after_mission(False)
        await drone.mission.upload_mission(MissionPlan(items))
        await drone.action.set_takeoff_altitude(params.altitude_m)
        await drone.action.set_return_to_launch_altitude(rtl_alt)
        if watcher is not None:
            watcher.start()
        await drone.action.arm()
        flying = True
        armed_at = vehicle_clock.now_s
        _log("armed", vehicle_time_s=armed_at)
        await drone.action.takeoff()
        await wait_for(
            drone.telemetry.position(),
            lambda p: p.relative_altitude_m >= 0.9 * params.altitude_m,
            climb_s + 60.0,
            "take-off altitude",
            vehicle_clock,
        )
        _log("took_off", vehicle_time_s=vehicle_clock.now_s)
        # Nobody leaves before the whole role is up, each at its own height: the way to the
        # strips then crosses the others' only at altitude_step_m apart, never a climbing one.
        highest = shared.own(env.role_count - 1)
        all_up_s = armed_at + climb_and_landing_s(highest)[0]
        wait_s = all_up_s - vehicle_clock.now_s
        if wait_s > 0:
            await vehicle_clock.sleep(wait_s, timeout_wall_s=60.0 + wait_s)
        await drone.mission.start_mission()
        surveying = True
        if watcher is not None:
            watcher.active.set()
        _log("mission_started", vehicle_time_s=vehicle_clock.now_s)

        async def settle_and_land() -> None:
            """Over home within LAND_ACCURACY_M, then land.

            The mission's last item is accepted up to 2 m away, and the neighbours' homes are
            a few metres off: descending there could put one vehicle on another.
            """
            alt_amsl = home.absolute_altitude_m + params.altitude_m
            await drone.action.goto_location(
                home.latitude_deg, home.longitude_deg, alt_amsl, math.nan
            )

            def over_home(p: Any) -> bool:
                n, e, _ = pymap3d.geodetic2ned(
                    p.latitude_deg, p.longitude_deg, 0.0, home.latitude_deg, home.longitude_deg, 0.0
                )
                return math.hypot(n, e) < LAND_ACCURACY_M

            await wait_for(drone.telemetry.position(), over_home, 60.0, "over home", vehicle_clock)
            await drone.action.land()

        async def go_home(here: np.ndarray) -> None:
            """Home now: around obstacles at the flight altitude, then land; else RTL."""
            router = Router(path.free_area) if path.free_area is not None else None
            if router is None or not router.contains(here[:2]):
                await drone.action.return_to_launch()  # at rtl_alt, clear of every solid
                return
            alt_amsl = home.absolute_altitude_m + params.altitude_m
            for x, y in [*router.path(here[:2], home_enu[:2]), home_enu[:2]]:
                lat, lon, _ = pymap3d.enu2geodetic(x, y, 0.0, *origin)
                await drone.action.goto_location(float(lat), float(lon), alt_amsl, math.nan)

                def arrived(p: Any, lat: float = float(lat), lon: float = float(lon)) -> bool:
                    n, e, _ = pymap3d.geodetic2ned(
                        p.latitude_deg, p.longitude_deg, 0.0, lat, lon, 0.0
                    )
                    return math.hypot(n, e) < 3.0

                await wait_for(
                    drone.telemetry.position(), arrived, 120.0, "way home", vehicle_clock
                )
            await settle_and_land()

        # Follow the mission; if it cannot end above home and land before the run's end (the
        # vehicle is slower than budgeted), return to launch at once.
        progress = [0, 0]

        async def follow_progress() -> None:
            async for m in drone.mission.mission_progress():
                progress[:] = [m.current, m.total]

        tasks.append(asyncio.create_task(follow_progress()))
        legs = np.hypot(*np.diff(mission_xy, axis=0).T)
        to_go = np.concatenate((np.cumsum(legs[::-1])[::-1], [0.0]))  # from item i to the end
        give_up_s = vehicle_clock.now_s + max(60.0, 3.0 * path.flight_time_s(params.speed_m_s))
        while not (progress[1] > 0 and progress[0] >= progress[1]):
            now = vehicle_clock.now_s
            if now > give_up_s:
                raise FlightError(f"the mission did not end by {give_up_s:.0f} s (vehicle time)")
            with lock:
                here = home_enu if pose.position_enu_m is None else pose.position_enu_m
            i = min(progress[0], len(mission_xy) - 1)
            remaining_m = float(np.hypot(*(mission_xy[i] - here[:2]))) + to_go[i]
            if now + finish_time_s(remaining_m, params, land_s) >= duration:
                _log("time_up", vehicle_time_s=now, remaining_m=round(remaining_m, 1))
                await go_home(here)
                break
            await asyncio.sleep(0.1)
        else:
            _log("mission_done", vehicle_time_s=vehicle_clock.now_s)
            await settle_and_land()  # above home: straight down
        surveying = False
        if watcher is not None:
            watcher.active.clear()
        await wait_for(drone.telemetry.in_air(), lambda a: not a, rtl_land_s + 120.0, "landing",
                        vehicle_clock)  # fmt: skip
        _log("landed", vehicle_time_s=vehicle_clock.now_s)
        await wait_for(drone.telemetry.armed(), lambda a: not a, 30, "auto-disarm", vehicle_clock)
        flying = False
        _log("disarmed", vehicle_time_s=vehicle_clock.now_s)
        if watcher is not None:
            with lock:
                seen = [s.position_enu_m.round(2).tolist() for s in watcher.counter.spills]
            _log("spills", positions_enu_m=seen, frames=watcher.frames, error=watcher.error)
    except BaseException:
        if flying:
            await return_after_failure(drone, "coverage")
        raise
    finally:
        for task in tasks:
            task.cancel()
        if watcher is not None:
            watcher.close()
        drone._stop_mavsdk_server()
    return _metrics(world, path, track, watcher)


def _metrics(
    world: Any, path: VehiclePlan, track: Track, watcher: CameraWatcher | None
) -> dict[str, tuple[Any, str]]:
    """The result's metrics: spills seen and in the footprint, distance, coverage of the strip."""
    footprints = track.footprints or []
    in_footprint: list[str] = []
    seen_names: list[str] = []
    if world is not None:
        spills = world_spills(world)
        for spill in spills:
            outline = spill.polygon
            if any(t >= spill.appear_s and f.intersects(outline) for t, f in footprints):
                in_footprint.append(spill.name)
        if watcher is not None:
            seen_names = matched_spills(spills, [s.position_enu_m for s in watcher.counter.spills])
    covered = shapely.union_all([f for _, f in footprints]) if footprints else None
    strip = path.part.polygon
    fraction = covered.intersection(strip).area / strip.area if covered is not None else 0.0
    metrics: dict[str, tuple[Any, str]] = {
        "spills_seen": (watcher.counter.count if watcher is not None else 0, "count"),
        "spills_in_footprint": (len(in_footprint), "count"),
        # which of the world's spills: the fleet's distinct count is the union of these lists
        "spills_seen_names": (sorted(seen_names), "names"),
        "spills_in_footprint_names": (sorted(in_footprint), "names"),
        "distance_flown_m": (round(track.distance_m, 2), "m"),
        "coverage_fraction": (round(float(fraction), 4), "1"),
        "camera_frames_used": (watcher.frames_used if watcher is not None else 0, "count"),
    }
    return metrics


MATCH_MARGIN_M = 5.0
"""A detection counts as a world spill when it lies within its outline grown by this, m."""


def matched_spills(spills: list[Any], detections_enu_m: list[np.ndarray]) -> list[str]:
    """Names of the world's spills the camera's distinct detections fall on (ground truth).

    For the report only (which spills were found, so that the fleet's count is of distinct
    spills); the detection itself never looks at the world.
    """
    names = set()
    for point in detections_enu_m:
        p = shapely.Point(float(point[0]), float(point[1]))
        near = [(s.polygon.distance(p), s.name) for s in spills]
        if near:
            distance, name = min(near)
            if distance <= MATCH_MARGIN_M:
                names.add(name)
    return sorted(names)


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> Any:
    """This role behind the swarm-scale engine's kinematic adapter (``companion.swarm``)."""
    from companion.swarm.coverage import CoverageProgram

    return CoverageProgram(env, vehicle, node)


def main(argv: list[str] | None = None) -> None:
    """Read the environment and options, fly, write result.json; exit 0, or 1 on a failure."""
    args = parser(__doc__, "src/worlds/examples/offshore.yaml", '{"altitude_m": 20}').parse_args(
        argv
    )

    def fly_with_params(env: ScenarioEnv) -> Mapping[str, tuple[Any, str]]:
        return run_flight(fly(env, CoverageParams.from_mapping(env.params)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
