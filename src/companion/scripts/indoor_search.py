"""Indoor search companion: fly through this vehicle's rooms of the plant, count the people seen.

The companion of the shipped ``indoor`` scenario (seed 000 S3, GPS-denied): K vehicles share the
plant's rooms (:mod:`companion.planning.indoor_route`, vehicle ``role_index`` of ``role_count``,
the split minimising the longest tour from the launch area). Each waits for a local position
estimate (external vision: the mocap bridge ``swarmsitl run`` starts), arms, takes off to
``altitude_m`` (+ ``role_index * altitude_step_m``), and flies offboard position + velocity
setpoints in local NED, streamed at ``setpoint_hz`` of simulated time, along a clear path
through the centres of its rooms and back to its start, where it lands before the run's
``duration_s`` ends (it turns back early when time runs short). Meanwhile it counts the people
in view of its forward camera: ground truth from the world (within ``detect_range_m``, in the
field of view, line of sight clear) and, with a camera stream, orange blobs in the frames
(:mod:`companion.perception.person_detector`). Writes ``result.json``: people_found,
people_in_view, rooms_visited, rooms_assigned, distance_flown_m; exits 0, or lands and exits 1
with the traceback on a failure.

Frames: the world is ENU; the vehicle flies in its EKF's local NED frame. With external vision
that frame is the motion-capture frame, whose origin is the world's origin
(docs/indoor_positioning.md), and its height origin is where the barometer started; the
companion takes the height of its first local position on the ground as the floor. Set
``local_origin_enu_m`` for a vision frame whose origin is elsewhere.

    python -m companion.scripts.indoor_search --url udpin://0.0.0.0:14540 --duration 180
        --world src/worlds/examples/indoor.yaml
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import sys
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from companion import clock
from companion.perception.camera_model import CameraModel, rotation_flu_enu_from_quaternion
from companion.perception.person_detector import (
    PersonColour,
    find_people,
    people_in_view,
    vertical_fov_deg,
)
from companion.perception.spill_detector import SpillCounter
from companion.perception.stream_reader import PosedStreamReader
from companion.planning.indoor_route import (
    IndoorPlanner,
    Route,
    RouteSpec,
    blocking_footprints,
    polyline_length,
    truncate_rooms,
)
from companion.role_params import params_from_mapping
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import finish, parser, run_flight, scenario_env
from companion.telemetry_waits import FlightError, connect, wait_for
from companion.vehicle_clock import VehicleClock

TRUTH_PERIOD_S = 0.2
"""Simulated seconds between two ground-truth field-of-view checks."""


@dataclass(frozen=True)
class SearchParams:
    """The role's arguments (``SWARMSITL_PARAMS``), SI units."""

    altitude_m: float = 1.5
    """Flight height above the floor of vehicle 0 of the role, m."""
    altitude_step_m: float = 1.2
    """Vehicle k flies ``k * altitude_step_m`` higher, so that paths through the same doorway
    never meet at one height, m (>= 0)."""
    speed_m_s: float = 2.0
    """Cruise speed along the path, m/s."""
    corner_speed_m_s: float = 0.5
    """Speed at a turn of the path, m/s."""
    accel_m_s2: float = 1.0
    """Acceleration of the setpoint between corners and cruise, m/s²."""
    margin_m: float = 0.55
    """Distance kept from walls and machinery, m (doorways are 1.5 m wide)."""
    resolution_m: float = 0.25
    """Planning grid cell, m."""
    detect_range_m: float = 8.0
    """A person within this distance, in view and in line of sight counts as in view, m."""
    hfov_deg: float = 114.59
    """Forward camera's horizontal field of view, degrees (the Typhoon H480's)."""
    camera_position_frd_m: tuple[float, float, float] = (0.16, 0.0, 0.12)
    """Optical centre from the centre of mass, body FRD, m (the Typhoon H480's mount)."""
    setpoint_hz: float = 20.0
    """Offboard setpoints per simulated second (PX4 needs > 2 Hz)."""
    depart_step_s: float = 6.0
    """Vehicle k leaves its take-off point ``k * depart_step_s`` after vehicle 0, s."""
    mean_speed_fraction: float = 0.6
    """Share of ``speed_m_s`` the vehicle averages along a path with turns, for the time budget."""
    reserve_s: float = 15.0
    """Simulated seconds kept free before the run's end (landing, disarm)."""
    merge_radius_m: float = 2.5
    """Camera detections closer than this are one person, m (the feet row places a person
    within about a metre at 8 m)."""
    min_detections: int = 3
    """A person counts as found once seen in this many frames (a blob in one frame whose pose
    lags the turning vehicle lands elsewhere)."""
    spin_deg_s: float = 60.0
    """At each room's centre the vehicle turns once around at this yaw rate, so that its forward
    camera sees the whole room, deg/s; 0: no turn."""
    local_origin_enu_m: tuple[float, float] | None = None
    """World ENU (east, north) of the local frame's origin; None: the world's origin (the
    motion-capture frame, docs/indoor_positioning.md)."""

    def __post_init__(self) -> None:
        positive = (
            "altitude_m", "speed_m_s", "corner_speed_m_s", "accel_m_s2", "margin_m",
            "resolution_m", "detect_range_m", "setpoint_hz", "merge_radius_m",
        )  # fmt: skip
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"PARAMS {name} must be a positive number, got {value!r}")
        if isinstance(self.min_detections, bool) or not (
            isinstance(self.min_detections, int) and self.min_detections >= 1
        ):
            raise ValueError(
                f"PARAMS min_detections must be an int >= 1, got {self.min_detections!r}"
            )
        for name in ("altitude_step_m", "depart_step_s", "reserve_s", "spin_deg_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"PARAMS {name} must be a number >= 0, got {value!r}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"PARAMS hfov_deg must be in (0, 180), got {self.hfov_deg!r}")
        if not 0.0 < self.mean_speed_fraction <= 1.0:
            raise ValueError(
                f"PARAMS mean_speed_fraction must be in (0, 1], got {self.mean_speed_fraction!r}"
            )
        if self.corner_speed_m_s > self.speed_m_s:
            raise ValueError("PARAMS corner_speed_m_s must not exceed speed_m_s")
        if self.setpoint_hz < 10.0:
            raise ValueError(f"PARAMS setpoint_hz must be >= 10, got {self.setpoint_hz!r}")
        position = tuple(float(v) for v in self.camera_position_frd_m)
        if len(position) != 3:
            raise ValueError("PARAMS camera_position_frd_m needs 3 numbers")
        object.__setattr__(self, "camera_position_frd_m", position)
        if self.local_origin_enu_m is not None:
            origin = tuple(float(v) for v in self.local_origin_enu_m)
            if len(origin) != 2 or not all(map(math.isfinite, origin)):
                raise ValueError("PARAMS local_origin_enu_m must be [east, north]")
            object.__setattr__(self, "local_origin_enu_m", origin)

    @classmethod
    def from_mapping(cls, params: Mapping[str, object] | None) -> SearchParams:
        """From the PARAMS JSON object; an unknown key is an error naming it."""
        return params_from_mapping(cls, params)

    @property
    def spin_s(self) -> float:
        """Simulated seconds of one turn around at a room's centre."""
        return 360.0 / self.spin_deg_s if self.spin_deg_s > 0 else 0.0

    def height_m(self, role_index: int) -> float:
        """Flight height of vehicle ``role_index`` of the role, m."""
        return self.altitude_m + role_index * self.altitude_step_m


PARAMS = SearchParams
"""The dataclass of this program's ``args``: ``swarmsitl run`` checks a role's ``args`` with it
when it loads the scenario (``companion.role_params``)."""


@dataclass(frozen=True)
class LocalFrame:
    """World ENU <-> the vehicle's local NED: horizontal origin and the floor's local down."""

    origin_en_m: tuple[float, float] = (0.0, 0.0)
    """World (east, north) of the local frame's origin, m."""
    floor_down_m: float = 0.0
    """Local down coordinate of the floor under the vehicle at the start, m."""

    def to_ned(self, xy_enu_m: np.ndarray, height_m: float) -> np.ndarray:
        """Local NED (3,) of the world point (east, north) at ``height_m`` above the floor."""
        e, n = float(xy_enu_m[0]), float(xy_enu_m[1])
        return np.array(
            [n - self.origin_en_m[1], e - self.origin_en_m[0], self.floor_down_m - height_m]
        )

    def to_enu(self, ned_m: np.ndarray) -> np.ndarray:
        """World ENU (3,) of a local NED point (up: height above the floor)."""
        n, e, d = (float(v) for v in ned_m)
        return np.array([e + self.origin_en_m[0], n + self.origin_en_m[1], self.floor_down_m - d])


def yaw_deg_ned(direction_en: np.ndarray) -> float:
    """PX4 yaw (degrees clockwise from north) of a horizontal ENU direction."""
    return math.degrees(math.atan2(float(direction_en[0]), float(direction_en[1])))


class Trajectory:
    """A polyline flown at a speed that slows to ``corner_speed`` at each turn."""

    def __init__(self, points_xy_m: np.ndarray, params: SearchParams) -> None:
        pts = np.asarray(points_xy_m, dtype=float).reshape(-1, 2)
        keep = [0] + [i for i in range(1, len(pts)) if np.hypot(*(pts[i] - pts[i - 1])) > 1e-6]
        self.points = pts[keep]
        legs = np.hypot(*np.diff(self.points, axis=0).T) if len(self.points) > 1 else np.zeros(0)
        self.arc = np.concatenate(([0.0], np.cumsum(legs)))
        self.length_m = float(self.arc[-1])
        self.params = params

    def point(self, s_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (2,) and unit direction (2,) at arc length ``s_m`` (clipped to the ends)."""
        if len(self.points) == 1:
            return self.points[0].copy(), np.array([0.0, 1.0])
        s = min(max(s_m, 0.0), self.length_m)
        i = min(int(np.searchsorted(self.arc, s, side="right")) - 1, len(self.points) - 2)
        leg = self.points[i + 1] - self.points[i]
        length = float(np.hypot(*leg))
        u = leg / length if length > 0 else np.array([0.0, 1.0])
        return self.points[i] + u * (s - self.arc[i]), u

    def speed(self, s_m: float) -> float:
        """Setpoint speed at ``s_m``, m/s.

        Cruise, limited by braking to the next corner and the end and by accelerating from the
        previous corner.
        """
        p = self.params
        if self.length_m == 0.0:
            return 0.0
        ahead = self.arc[self.arc > s_m + 1e-9]
        behind = self.arc[self.arc <= s_m + 1e-9]
        d_next = (ahead[0] - s_m) if len(ahead) else 0.0
        d_prev = s_m - behind[-1] if len(behind) else 0.0
        end_speed = 0.0 if len(ahead) <= 1 else p.corner_speed_m_s
        start_speed = p.corner_speed_m_s
        v = min(
            p.speed_m_s,
            math.sqrt(end_speed**2 + 2.0 * p.accel_m_s2 * max(d_next, 0.0)),
            math.sqrt(start_speed**2 + 2.0 * p.accel_m_s2 * max(d_prev, 0.0)),
        )
        return max(v, 0.2 if s_m < self.length_m else 0.0)

    def time_s(self, from_s_m: float = 0.0) -> float:
        """Simulated seconds to fly from ``from_s_m`` to the end on the speed profile."""
        return float(np.interp(from_s_m, self._grid_m, self._to_end_s))

    @cached_property
    def _grid_m(self) -> np.ndarray:
        return np.append(np.arange(0.0, self.length_m, 0.25), self.length_m)

    @cached_property
    def _to_end_s(self) -> np.ndarray:
        grid = self._grid_m
        steps = np.diff(grid) / np.maximum([self.speed(s) for s in grid[:-1]], 0.2)
        return np.append(np.cumsum(steps[::-1])[::-1], 0.0)


def plan_route(
    planner: IndoorPlanner,
    reference_xy: tuple[float, float],
    start_xy: tuple[float, float],
    role_index: int,
    role_count: int,
    budget_m: float,
) -> tuple[Route, tuple[int, ...]]:
    """This vehicle's route (the prefix of its rooms that fits ``budget_m``) and its rooms."""
    parts = planner.split(reference_xy, role_count)
    mine = parts[role_index] if role_index < len(parts) else ()
    return truncate_rooms(planner, start_xy, mine, budget_m), mine


def fitting_route(
    planner: IndoorPlanner,
    start_xy: tuple[float, float],
    rooms: tuple[int, ...],
    budget_s: float,
    params: SearchParams,
) -> Route:
    """The route through the most of ``rooms`` that fits ``budget_s`` with a turn at each.

    The distance a budget allows depends on how many turns it must also hold: for each number
    of turns n the most rooms whose tour fits the rest are found, and kept if they are at most
    n (their turns fit); the largest such route wins.
    """
    best = planner.route(start_xy, ())
    for count in range(len(rooms), 0, -1):
        budget_m = (budget_s - count * params.spin_s) * params.speed_m_s
        route = truncate_rooms(planner, start_xy, rooms, budget_m * params.mean_speed_fraction)
        if count >= len(route.rooms) > len(best.rooms):
            best = route
    return best


def room_arcs(route: Route) -> dict[int, float]:
    """Arc length along the route's waypoints at which each visited room's goal lies, m."""
    legs = np.hypot(*np.diff(route.waypoints_xy_m, axis=0).T)
    arc = np.concatenate(([0.0], np.cumsum(legs)))
    return {room: float(arc[k]) for room, k in zip(route.rooms, route.room_waypoint, strict=True)}


def launch_reference(world: Any, start_xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (east, north) of the launch area holding ``start_xy``, and the distance from it.

    The rooms are split from that point, the same for every vehicle; a start on no launch area
    (within its radius + 2 m) gives ``start_xy`` and an infinite distance.
    """
    best, best_d = np.asarray(start_xy, dtype=float)[:2], math.inf
    for area in world.launch_areas:
        c = np.asarray(area.center_enu_m[:2], dtype=float)
        d = float(np.hypot(*(c - start_xy[:2])))
        if d <= area.radius_m + 2.0 and d < best_d:
            best, best_d = c, d
    return best, best_d


@dataclass
class Pose:
    """Latest telemetry in world ENU."""

    position_enu_m: np.ndarray | None = None
    rotation_flu_enu: np.ndarray | None = None


@dataclass
class Tally:
    """What the flight saw and did."""

    distance_m: float = 0.0
    last_enu_m: np.ndarray | None = None
    in_view: set[int] = field(default_factory=set)
    last_truth_s: float = -math.inf
    rooms_visited: set[int] = field(default_factory=set)


def _log(name: str, **data: Any) -> None:
    print(f"[indoor_search] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


class CameraWatcher(PosedStreamReader):
    """Reads the video stream in a thread and counts the orange people it finds while active."""

    def __init__(self, uri: str, params: SearchParams, pose: Pose, lock: threading.Lock) -> None:
        super().__init__(uri, pose, lock, "indoor-camera")
        self.params = params
        self.counter = SpillCounter(merge_radius_m=params.merge_radius_m)
        self.colour = PersonColour()

    @property
    def count(self) -> int:
        """People seen: places with at least ``min_detections`` sightings."""
        return sum(s.detections >= self.params.min_detections for s in self.counter.spills)

    def camera_for(self, width_px: int, height_px: int) -> CameraModel:
        """The forward camera of the params, sized to the frames."""
        return CameraModel(
            width_px=width_px,
            height_px=height_px,
            hfov_deg=self.params.hfov_deg,
            pitch_deg=0.0,
            position_frd_m=self.params.camera_position_frd_m,
        )

    def use(
        self, rgb: np.ndarray, camera: CameraModel, position: np.ndarray, rotation: Any
    ) -> None:
        """Find the people in one frame within range, whole in view; count the new ones."""
        detections = [
            d
            for d in find_people(rgb, camera, position, rotation, self.colour)
            if not d.blob.touches_border
            and np.hypot(*(np.subtract(d.position_enu_m[:2], position[:2])))
            <= self.params.detect_range_m
        ]
        with self.lock:
            before = self.count
            self.counter.add(detections)
            after = self.count
        if after > before:
            _log(
                "person_seen",
                count=after,
                at_enu_m=[np.round(d.position_enu_m, 2).tolist() for d in detections],
            )


async def fly(env: ScenarioEnv, params: SearchParams) -> dict[str, tuple[Any, str]]:
    """The whole flight; returns the metrics for ``result.json``."""
    from mavsdk_grpc import System
    from mavsdk_grpc.offboard import PositionNedYaw, VelocityNedYaw

    if env.world is None:
        raise FlightError("indoor_search needs the world (SWARMSITL_WORLD) to plan in")
    import worlds

    world = worlds.build(worlds.load_world(env.world))
    height = params.height_m(env.role_index)
    planner = IndoorPlanner(
        world,
        RouteSpec(altitude_m=height, margin_m=params.margin_m, resolution_m=params.resolution_m),
    )
    people = [t for t in world.targets if type(t).__name__ == "Person"]
    people_xyz = np.array([p.position_enu_m for p in people], dtype=float).reshape(-1, 3)
    people_h = np.array([p.height_m for p in people], dtype=float)
    sight_blockers = blocking_footprints(world, height, 0.0)
    duration = env.duration_s if env.duration_s is not None else math.inf
    vehicle_clock = VehicleClock()
    lock = threading.Lock()
    pose = Pose()
    tally = Tally()
    frame: list[LocalFrame | None] = [None]
    local_ned: list[np.ndarray | None] = [None]
    armed = [False]
    watcher = (
        CameraWatcher(env.video_uri, params, pose, lock) if env.video_uri is not None else None
    )
    vfov = vertical_fov_deg(params.hfov_deg, 4, 3)  # ground truth assumes a 4:3 frame

    async def attitudes() -> None:
        async for q in drone.telemetry.attitude_quaternion():
            vehicle_clock.feed(q.timestamp_us)
            with lock:
                pose.rotation_flu_enu = rotation_flu_enu_from_quaternion(q.w, q.x, q.y, q.z)

    async def positions() -> None:
        async for pv in drone.telemetry.position_velocity_ned():
            ned = np.array([pv.position.north_m, pv.position.east_m, pv.position.down_m])
            local_ned[0] = ned
            if frame[0] is None:
                continue
            here = frame[0].to_enu(ned)
            with lock:
                pose.position_enu_m = here
                rotation = pose.rotation_flu_enu
            if tally.last_enu_m is not None and armed[0]:
                tally.distance_m += float(np.linalg.norm(here - tally.last_enu_m))
            tally.last_enu_m = here
            now = vehicle_clock.now_s if vehicle_clock.started else math.nan
            if armed[0] and rotation is not None and now - tally.last_truth_s >= TRUTH_PERIOD_S:
                tally.last_truth_s = now
                forward = rotation[:, 0]
                camera = here + rotation @ (np.array(params.camera_position_frd_m) * [1, -1, -1])
                seen = people_in_view(
                    people_xyz,
                    people_h,
                    camera,
                    math.atan2(forward[1], forward[0]),
                    params.hfov_deg,
                    vfov,
                    params.detect_range_m,
                    sight_blockers,
                )
                for k in np.flatnonzero(seen):
                    if int(k) not in tally.in_view:
                        tally.in_view.add(int(k))
                        _log("person_in_view", person=people[int(k)].name, vehicle_time_s=now)

    async def armed_state() -> None:
        async for a in drone.telemetry.armed():
            armed[0] = a

    drone = System(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    flying = False
    route: Route | None = None
    assigned: tuple[int, ...] = ()
    try:
        _log("connecting", url=env.mavlink_url, grpc_port=env.grpc_port, rooms=len(planner.rooms))
        await connect(drone, env.mavlink_url, env.grpc_port)
        tasks.append(asyncio.create_task(attitudes()))
        await vehicle_clock.wait_started(60.0)
        tasks += [asyncio.create_task(positions()), asyncio.create_task(armed_state())]
        _log("connected", vehicle_time_s=vehicle_clock.now_s)
        # No GNSS indoors: the local position (external vision) is what arming and offboard
        # need; there is no global position and no HOME_POSITION (PX4 sends it only with one).
        await wait_for(
            drone.telemetry.health(),
            lambda h: h.is_local_position_ok and h.is_armable,
            60,
            "local position estimate",
            vehicle_clock,
        )
        while local_ned[0] is None:
            await clock.sleep(0.1)
        ned0 = local_ned[0]
        origin = params.local_origin_enu_m or (0.0, 0.0)
        frame[0] = LocalFrame(origin, float(ned0[2]))
        start = frame[0].to_enu(ned0)[:2]
        reference, off = launch_reference(world, start)
        if not math.isfinite(off):
            raise FlightError(
                f"the first local position puts the vehicle at ENU {start.round(2).tolist()}, "
                "on none of the world's launch areas: is the local frame the world's? "
                "(PARAMS local_origin_enu_m)"
            )
        now = vehicle_clock.now_s
        climb_s = height / 0.7 + 5.0
        land_s = height / 0.5 + 10.0
        depart_s = env.role_index * params.depart_step_s
        budget_s = duration - now - climb_s - depart_s - land_s - params.reserve_s
        route, assigned = plan_route(planner, tuple(reference), tuple(start), env.role_index,
                                     env.role_count, math.inf)  # fmt: skip
        budget_m = (budget_s - len(assigned) * params.spin_s) * params.speed_m_s
        budget_m *= params.mean_speed_fraction
        if budget_m < route.length_m:
            route = fitting_route(planner, tuple(start), assigned, budget_s, params)
            budget_m = route.length_m
        trajectory = Trajectory(route.waypoints_xy_m, params)
        _log(
            "planned",
            rooms=list(route.rooms),
            assigned=list(assigned),
            length_m=round(route.length_m, 1),
            budget_m=round(budget_m, 1),
            flight_s=round(trajectory.time_s(), 1),
            start_enu_m=start.round(2).tolist(),
            height_m=height,
        )
        if watcher is not None:
            watcher.start()
        await drone.action.set_takeoff_altitude(height)
        await drone.action.arm()
        flying = True
        armed_at = vehicle_clock.now_s
        _log("armed", vehicle_time_s=armed_at)
        await drone.action.takeoff()
        await wait_for(
            drone.telemetry.position_velocity_ned(),
            lambda p: frame[0].floor_down_m - p.position.down_m >= 0.9 * height,
            climb_s + 30.0,
            "take-off height",
            vehicle_clock,
        )
        _log("took_off", vehicle_time_s=vehicle_clock.now_s)
        leave_at = armed_at + climb_s + depart_s
        if leave_at > vehicle_clock.now_s:
            await vehicle_clock.sleep(leave_at - vehicle_clock.now_s, 60.0 + leave_at)
        if watcher is not None:
            watcher.active.set()
        await follow(drone, trajectory, route, frame[0], params, height, pose, lock, tally,
                     planner, duration - land_s - params.reserve_s / 2, vehicle_clock,
                     PositionNedYaw, VelocityNedYaw)  # fmt: skip
        await drone.action.land()
        if watcher is not None:
            watcher.active.clear()
        await wait_for(drone.telemetry.in_air(), lambda a: not a, land_s + 60.0, "landing",
                       vehicle_clock)  # fmt: skip
        _log("landed", vehicle_time_s=vehicle_clock.now_s)
        await wait_for(drone.telemetry.armed(), lambda a: not a, 30, "auto-disarm", vehicle_clock)
        flying = False
        _log("disarmed", vehicle_time_s=vehicle_clock.now_s)
    except BaseException:
        if flying:
            try:
                await asyncio.wait_for(drone.action.land(), 10.0)
                print("[indoor_search] error: landing here", file=sys.stderr, flush=True)
            except Exception:  # the vehicle's own failsafe takes over
                pass
        raise
    finally:
        for task in tasks:
            task.cancel()
        if watcher is not None:
            watcher.close()
        drone._stop_mavsdk_server()
    in_view_names = sorted(people[k].name for k in tally.in_view)
    metrics: dict[str, tuple[Any, str]] = {
        "people_in_view": (len(tally.in_view), "count"),
        # which people: the run report's fleet.companions gives the union (each person once)
        "people_in_view_names": (in_view_names, "names"),
        "rooms_visited": (len(tally.rooms_visited), "count"),
        "rooms_assigned": (len(assigned), "count"),
        "distance_flown_m": (round(tally.distance_m, 2), "m"),
    }
    if watcher is not None:
        metrics["people_found"] = (watcher.count, "count")
        metrics["camera_frames_used"] = (watcher.frames_used, "count")
        found = [
            s.position_enu_m
            for s in watcher.counter.spills
            if s.detections >= params.min_detections
        ]
        metrics["people_found_names"] = (matched_people(people, found), "names")
    else:
        metrics["people_found"] = (len(tally.in_view), "count")
        metrics["people_found_names"] = (in_view_names, "names")
    return metrics


MATCH_RADIUS_M = 2.5
"""A camera finding names the person standing within this of where it was placed, m."""


def matched_people(people: list[Any], found_enu_m: list[np.ndarray]) -> list[str]:
    """Names of the world's people the camera's findings stand on (ground truth, report only)."""
    names = set()
    for point in found_enu_m:
        near = [
            (math.hypot(p.position_enu_m[0] - point[0], p.position_enu_m[1] - point[1]), p.name)
            for p in people
        ]
        if near and min(near)[0] <= MATCH_RADIUS_M:
            names.add(min(near)[1])
    return sorted(names)


async def follow(
    drone: Any,
    trajectory: Trajectory,
    route: Route,
    frame: LocalFrame,
    params: SearchParams,
    height: float,
    pose: Pose,
    lock: threading.Lock,
    tally: Tally,
    planner: IndoorPlanner,
    land_by_s: float,
    vehicle_clock: VehicleClock,
    position_type: Any,
    velocity_type: Any,
) -> None:
    """Stream offboard setpoints along ``trajectory`` until the vehicle is back at its end.

    The setpoint (a carrot) moves along the path at the profile's speed but waits for the
    vehicle when it lags by more than 1.5 m; when the rest of the path no longer fits before
    ``land_by_s`` the vehicle turns back to the path's end at once.
    """
    goals = {
        i: route.waypoints_xy_m[k] for i, k in zip(route.rooms, route.room_waypoint, strict=True)
    }
    dt = 1.0 / params.setpoint_hz

    def setpoint(s: float, speed: float) -> tuple[Any, Any]:
        xy, u = trajectory.point(s)
        ahead, _ = trajectory.point(s + 1.0)
        look = ahead - xy
        yaw = yaw_deg_ned(look if np.hypot(*look) > 0.05 else u)
        n, e, d = frame.to_ned(xy, height)
        return (
            position_type(float(n), float(e), float(d), yaw),
            velocity_type(float(u[1] * speed), float(u[0] * speed), 0.0, yaw),
        )

    arcs = sorted((arc, room) for room, arc in room_arcs(route).items())
    spin: tuple[float, float] | None = None
    """(start time, yaw at the start) of the turn at a room's centre, while turning."""
    s = 0.0
    pos, vel = setpoint(0.0, 0.0)
    await drone.offboard.set_position_velocity_ned(pos, velocity_type(0.0, 0.0, 0.0, pos.yaw_deg))
    await drone.offboard.start()
    _log("offboard", vehicle_time_s=vehicle_clock.now_s, length_m=round(trajectory.length_m, 1))
    turned_back = False
    last = clock.now_s()
    settled_since = math.inf
    while True:
        now = clock.now_s()
        step = min(max(now - last, 0.0), 0.5)
        last = now
        with lock:
            here = pose.position_enu_m
        carrot, _ = trajectory.point(s)
        lag = float(np.hypot(*(carrot - here[:2]))) if here is not None else 0.0
        speed = trajectory.speed(s)
        vt = vehicle_clock.now_s
        if spin is not None and vt - spin[0] >= params.spin_s:
            spin = None
        if spin is None and lag < 1.5:
            s_next = min(s + speed * step, trajectory.length_m)
            if not turned_back and arcs and arcs[0][0] <= s_next and params.spin_s > 0:
                s_next = arcs.pop(0)[0]
                spin = (vt, setpoint(max(s_next - 1.0, 0.0), 0.0)[0].yaw_deg)
            s = s_next
        if here is not None:
            for room, goal in goals.items():
                if room not in tally.rooms_visited and np.hypot(*(goal - here[:2])) < 1.0:
                    tally.rooms_visited.add(room)
                    _log("room_visited", room=room, vehicle_time_s=vehicle_clock.now_s)
        rest_s = trajectory.time_s(s) + params.spin_s * (len(arcs) + (spin is not None))
        if not turned_back and vt + rest_s > land_by_s:
            home = trajectory.points[-1]
            back = planner.path(carrot, home)
            trajectory = Trajectory(back, params)
            s, turned_back, spin = 0.0, True, None
            _log("time_up", vehicle_time_s=vt, back_m=round(polyline_length(back), 1))
        if spin is not None:
            pos, _ = setpoint(s, 0.0)
            yaw = spin[1] + params.spin_deg_s * (vt - spin[0])
            yaw = (yaw + 180.0) % 360.0 - 180.0
            pos = position_type(pos.north_m, pos.east_m, pos.down_m, yaw)
            vel = velocity_type(0.0, 0.0, 0.0, yaw)
        else:
            pos, vel = setpoint(s, speed if s < trajectory.length_m else 0.0)
        await drone.offboard.set_position_velocity_ned(pos, vel)
        if s >= trajectory.length_m and here is not None:
            if float(np.hypot(*(trajectory.points[-1] - here[:2]))) < 0.3:
                settled_since = min(settled_since, vt)
                if vt - settled_since >= 1.0:
                    break
            if vt > land_by_s + 10.0:
                break
        await clock.sleep(dt)
    _log("route_done", vehicle_time_s=vehicle_clock.now_s, turned_back=turned_back)


def main(argv: list[str] | None = None) -> None:
    """Read the environment and options, fly, write result.json; exit 0, or 1 on a failure."""
    args = parser(__doc__, "src/worlds/examples/indoor.yaml", '{"altitude_m": 1.5}').parse_args(
        argv
    )

    def fly_with_params(env: ScenarioEnv) -> Mapping[str, tuple[Any, str]]:
        return run_flight(fly(env, SearchParams.from_mapping(env.params)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
