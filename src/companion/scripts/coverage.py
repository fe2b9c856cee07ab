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
import sys
import threading
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import pymap3d
import shapely
from shapely.geometry import box

from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_quaternion
from companion.perception.spill_detector import DetectorConfig, SpillCounter, detect_spills
from companion.perception.stream_reader import PosedStreamReader
from companion.planning.coverage import (
    CoverageSpec,
    Router,
    VehiclePlan,
    plan_vehicle,
    reachable_area,
)
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import finish, parser, scenario_env
from companion.telemetry_waits import FlightError, connect, first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock

LAND_ACCURACY_M = 0.5
"""Horizontal distance from home within which the vehicle starts its descent, m."""
FOOTPRINT_PERIOD_S = 0.5
"""Simulated seconds between two camera footprints of the ground-truth track."""
DEFAULT_ORIGIN = (47.397742, 8.545594, 488.0)
"""World origin if none is given (swarmsitl's default), lat, lon (deg), AMSL (m)."""


@dataclass(frozen=True)
class CoverageParams:
    """The role's arguments (``SWARMSITL_PARAMS``), SI units."""

    altitude_m: float = 30.0
    """Flight height above the launch point, m."""
    speed_m_s: float = 10.0
    """Speed along the lanes, m/s."""
    overlap: float = 0.2
    """Fraction of the footprint width neighbouring lanes share."""
    hfov_deg: float = 114.59
    """Camera horizontal field of view, degrees (the Typhoon H480's)."""
    camera_pitch_deg: float = -90.0
    """Camera elevation above the body's forward axis, degrees (-90: down)."""
    area_enu_m: tuple[float, float, float, float] | None = None
    """Rectangle (x_min, y_min, x_max, y_max) to cover, world ENU m; None: the world's boundary,
    cut to the square around the launch point the fleet can sweep in the run's time
    (``coverage.reachable_area``), or with no world a 200 m square around the launch point."""
    sweep_deg: float | None = None
    """Lane direction, degrees counter-clockwise from east; None: along the area's longer side."""
    margin_m: float = 10.0
    """Horizontal distance kept from solids that reach the flight height, and no-fly zones, m."""
    climb_m_s: float = 1.5
    """Climb rate the take-off is budgeted with, m/s (PX4's MPC_TKO_SPEED)."""
    descent_m_s: float = 1.0
    """Mean descent rate the landing is budgeted with, m/s (MPC_Z_V_AUTO_DN, MPC_LAND_SPEED)."""
    mean_speed_fraction: float = 0.7
    """Share of ``speed_m_s`` the vehicle averages along its path, with the accelerations and
    turns (measured: about 0.6 to 0.8 on 100 to 200 m lanes), for the time budget; in (0, 1]."""
    reserve_s: float = 10.0
    """Extra simulated seconds kept free before the run's end."""
    merge_radius_m: float = 10.0
    """Detections closer than this are one spill, m."""
    dark_max: int = 28
    """Brightest channel of an oil pixel, 0..255."""
    altitude_step_m: float = 4.0
    """Vehicle k of the role (``ROLE_INDEX``) flies ``altitude_m + k * altitude_step_m`` above
    its launch point, so that vehicles crossing each other's way to and from their strips pass
    at different heights; the lanes are spaced for ``altitude_m``, the lowest footprint."""

    def own(self, role_index: int) -> CoverageParams:
        """These parameters with the flight height of vehicle ``role_index`` of the role."""
        return dataclasses.replace(
            self, altitude_m=self.altitude_m + role_index * self.altitude_step_m
        )

    def __post_init__(self) -> None:
        positive = ("altitude_m", "speed_m_s", "climb_m_s", "descent_m_s")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"PARAMS {name} must be a positive number, got {value!r}")
        step = self.altitude_step_m
        if not (isinstance(step, (int, float)) and math.isfinite(step) and step >= 0):
            raise ValueError(f"PARAMS altitude_step_m must be a number >= 0, got {step!r}")
        if not 0.0 < self.mean_speed_fraction <= 1.0:
            raise ValueError(
                f"PARAMS mean_speed_fraction must be in (0, 1], got {self.mean_speed_fraction!r}"
            )
        if self.area_enu_m is not None:
            area = tuple(float(v) for v in self.area_enu_m)
            if len(area) != 4 or not (area[0] < area[2] and area[1] < area[3]):
                raise ValueError(
                    f"PARAMS area_enu_m must be [x_min, y_min, x_max, y_max], got {self.area_enu_m}"
                )
            object.__setattr__(self, "area_enu_m", area)

    @property
    def mean_speed_m_s(self) -> float:
        """The speed the time budget assumes, m/s."""
        return self.speed_m_s * self.mean_speed_fraction

    @classmethod
    def from_mapping(cls, params: Mapping[str, object] | None) -> CoverageParams:
        """From the PARAMS JSON object; an unknown key is an error naming it."""
        params = dict(params or {})
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(params) - known)
        if unknown:
            raise ValueError(f"PARAMS: unknown key(s) {unknown}; known: {sorted(known)}")
        return cls(**params)  # type: ignore[arg-type]


def _log(name: str, **data: Any) -> None:
    print(f"[coverage] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


def _load_world(env: ScenarioEnv) -> Any:
    """The run's world (``worlds.World``), or None."""
    if env.world is None:
        return None
    import worlds

    return worlds.build(worlds.load_world(env.world))


def _obstacles(world: Any, flight_z_m: float, clearance_m: float = 5.0) -> list:
    """Footprints of the solids reaching within ``clearance_m`` of the flight height, no-fly."""
    if world is None:
        return []
    from worlds.maps import obstacle_polygons

    out = list(world.no_fly)
    for z in np.arange(flight_z_m - clearance_m, flight_z_m + clearance_m + 0.5, 1.0):
        out.extend(obstacle_polygons(world, float(z), include_no_fly=False))
    return out


def climb_and_landing_s(
    params: CoverageParams, return_altitude_m: float | None = None
) -> tuple[float, float]:
    """Simulated seconds budgeted for the take-off, and for the return's climb, descent, landing.

    ``return_altitude_m``: the return-to-launch altitude above home (default: ``altitude_m``);
    a higher one adds the climb to it and its longer descent. 10 s cover the return's
    accelerations and the land detector.
    """
    rtl = params.altitude_m if return_altitude_m is None else return_altitude_m
    climb_back = max(rtl - params.altitude_m, 0.0) / params.climb_m_s
    return (
        params.altitude_m / params.climb_m_s + 5.0,
        climb_back + rtl / params.descent_m_s + 10.0,
    )


def return_altitude_m(
    world: Any,
    home_enu_m: np.ndarray,
    waypoints_enu_m: np.ndarray,
    altitude_m: float,
    clearance_m: float = 5.0,
) -> float:
    """Return-to-launch altitude above home that clears every solid on the way back, m.

    The return flies straight from wherever the vehicle is to home: any solid under the hull
    of the path and home (grown by ``clearance_m``) must be ``clearance_m`` below it. Moving
    solids count over their whole range of motion.
    """
    if world is None or len(waypoints_enu_m) == 0:
        return altitude_m
    points = np.vstack([np.asarray(home_enu_m)[:2], np.asarray(waypoints_enu_m)[:, :2]])
    region = shapely.MultiPoint(points).convex_hull.buffer(clearance_m)
    tops = []
    for solid in world.solids:
        if solid.motion is None:
            footprint, top = solid.footprint_at(0.0), solid.z_range_at(0.0)[1]
        else:
            footprint = box(*solid.motion.bounds_xy_m).buffer(max(solid.size_m[:2]) / 2.0)
            top = solid.z_range_at(0.0)[1] + abs(solid.motion.vertical_amplitude_m) * 2.0
        if footprint.intersects(region):
            tops.append(top)
    needed = max(tops, default=-math.inf) + clearance_m - float(home_enu_m[2])
    return max(altitude_m, needed)


def reference_point(world: Any, home_enu_m: np.ndarray) -> np.ndarray:
    """The point the vehicles of one launch area split the area from: that area's centre.

    Vehicles on the same helideck have homes a few metres apart (and their GPS altitudes
    differ): the split must not depend on them, or the strips would overlap. A vehicle whose
    home is on none of the world's launch areas (within its radius plus 5 m) uses its home.
    """
    home = np.asarray(home_enu_m, dtype=float)
    for area in world.launch_areas if world is not None else ():
        centre = np.asarray(area.center_enu_m, dtype=float)
        if np.hypot(*(centre[:2] - home[:2])) <= area.radius_m + 5.0:
            return centre
    return home


def plan(
    env: ScenarioEnv,
    params: CoverageParams,
    world: Any,
    home_enu_m: np.ndarray,
    budget_s: float | None,
) -> VehiclePlan:
    """This vehicle's coverage path in world ENU (z = flight height above the sea/ground).

    The area and its split depend only on what every vehicle of the role shares (world, launch
    area, params, the run's duration), so the K strips fit together; the order of the lanes,
    the cut to ``budget_s`` (what is left of this vehicle's time) and the legs from and to the
    start use the vehicle's own home.
    """
    ref = reference_point(world, home_enu_m)
    flight_z = float(ref[2]) + params.altitude_m
    spec = CoverageSpec(
        altitude_m=flight_z,
        hfov_deg=params.hfov_deg,
        overlap=params.overlap,
        sweep_deg=params.sweep_deg,
        margin_m=params.margin_m,
    )
    if params.area_enu_m is not None:
        area = box(*params.area_enu_m)
    elif world is not None:
        area = world.boundary
        if env.duration_s is not None:
            overhead = sum(climb_and_landing_s(params)) + params.reserve_s
            reach = params.mean_speed_m_s * max(env.duration_s - overhead, 1.0)
            area = reachable_area(area, ref[:2], env.role_count, spec, reach)
    else:
        area = shapely.Point(ref[:2]).buffer(100.0, cap_style="square")
    return plan_vehicle(
        area,
        _obstacles(world, flight_z),
        spec,
        env.role_count,
        env.role_index,
        home_enu_m[:2],
        params.mean_speed_m_s,
        budget_s,
    )


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
            e, n, u = pymap3d.geodetic2enu(
                p.latitude_deg, p.longitude_deg, p.absolute_altitude_m, *origin
            )
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
    drone = System(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    flying = False
    try:
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
            items.append(
                MissionItem(
                    latitude_deg=float(lat),
                    longitude_deg=float(lon),
                    relative_altitude_m=params.altitude_m,
                    speed_m_s=params.speed_m_s,
                    is_fly_through=True,
                    gimbal_pitch_deg=math.nan,
                    gimbal_yaw_deg=math.nan,
                    camera_action=MissionItem.CameraAction.NONE,
                    loiter_time_s=0.0,
                    camera_photo_interval_s=math.nan,
                    acceptance_radius_m=2.0,
                    yaw_deg=math.nan,  # face the direction of travel: the lanes across the image
                    camera_photo_distance_m=math.nan,
                    vehicle_action=MissionItem.VehicleAction.NONE,
                )
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
            try:
                await asyncio.wait_for(drone.action.return_to_launch(), 10.0)
                print("[coverage] error: returning to launch", file=sys.stderr, flush=True)
            except Exception:  # the vehicle's own failsafe takes over
                pass
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


def world_spills(world: Any) -> list[Any]:
    """The world's oil spills (none without a world)."""
    if world is None:
        return []
    from worlds import OilSpill

    return list(world.targets_of(OilSpill))


def finish_time_s(remaining_m: float, params: CoverageParams, land_s: float) -> float:
    """Simulated seconds to fly the rest of the mission, settle and land, with half the reserve.

    When the run's end comes sooner, the vehicle turns home at once (both adapters use this).
    """
    return remaining_m / params.mean_speed_m_s + land_s + params.reserve_s / 2


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
        return asyncio.run(fly(env, CoverageParams.from_mapping(env.params)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
