"""Seed 001's ACO swarm role: each UAV plans its own path, avoids collisions, keeps a formation.

Every vehicle runs :class:`companion.swarm.aco.AcoProgram`: take off at its spawn point in the
world's ``start`` zone, plan start -> its mirror point in the ``goal`` zone (option 2: the
formation translated) over a roadmap (ACO, or A* as the baseline), fly it at ``speed_m_s``
broadcasting its position and priority (topic ``aco``), run Alg. 2 (collision avoidance) every
decision and, with ``option: 2``, Alg. 4 (formation conservation), and land at the target. The
choices are in ``companion.swarm.aco`` and ``companion.planning.aco.{avoidance,formation,
metrics}``. Both adapters run that very program; they only carry commands and observations:

* Swarm fidelity (``swarm_program``): in-process, the engine's kinematic vehicle is the
  program's :class:`~companion.swarm.aco.AcoVehicle`, one decision per engine decision
  (``swarm.decision_hz``); the engine's ``sense`` sees solids and vehicles by truth.
* Full stack (``main``, ``python -m companion.scripts.aco_swarm``): this program, MAVSDK only
  (``mavsdk_grpc``, else ``mavsdk`` < 4), as on a Raspberry Pi beside a PX4.
  :class:`MavsdkVehicle` is the program's vehicle: its estimated position (LOCAL_POSITION_NED
  in the world's ENU frame, :class:`LocalFrame`), take-off with ``action.takeoff`` to
  ``altitude_m``, then Offboard: the path flown with velocity setpoints
  (:class:`companion.offboard_path.PathFollower`: fly-through waypoints within 2 m, the speed
  along the leg and back onto it), a hold as a zero velocity setpoint, the landing with
  ``action.land``. One
  decision every ``decision_period_s`` (0.1 s) of the *vehicle's* clock (its telemetry stamps:
  the simulation's time under swarmsitl). Messages: :class:`companion.net.radio.Radio`
  (``SWARMSITL_NET``/``SWARMSITL_NODE``; the scenario's fleet needs ``node: edge``). Priority:
  ``ScenarioEnv.priority`` (the fleet entry's, default the vehicle number, as the swarm
  engine's). Obstacles: :class:`ObstacleSensor`, an idealised detector standing for UTSim's
  (below). The speed is capped at the autopilot's MPC_XY_VEL_MAX (:func:`full_stack_params`).
  A vehicle found disarmed after it armed ends the program quietly (phase ``down``); close to
  the run's end (``duration_s`` less ``GIVE_UP_RESERVE_S``) a program still flying, and not
  landing at its target, lands where it is (phase ``timeout``).

Sensing on the full stack. The companion has no obstacle truth; seed 001's UAVs detect what is
within R_s in UTSim. :class:`ObstacleSensor` stands for that detection and is exact (no noise,
no occlusion, no missed detection): the world file's solids, static ones and moving ones where
``worlds.model.motion_centers`` (the one motion law the simulator also flies them by) puts them
at the vehicle's time, measured from the vehicle's *estimated* position (a GNSS error shifts
what it sees as it would shift a map-registered sensor); other vehicles as their last messages
put them (extrapolated to now with their velocity, dropped after ``PEER_STALE_S``), spheres of
their airframe's diameter (``SWARMSITL_FLEET``'s ``diameter_m``).

``result.json``: ``AcoProgram.metrics()``, the same names and units at both fidelities
(``reached``, ``min_dist_m``, ``total_dist_m``, ``travel_time_s``, ``mission_start_s``,
``arrived_s``, ``divergences``, ``holds``, ``avg_dist_change_m``, ``plan_ms``,
``path_length_m``, ``option``, ``phase``), so that ``run_metrics`` reads a report of either.

    python -m companion.scripts.aco_swarm --world src/worlds/examples/arena_aco.yaml \
        --params '{"option": 2}' --role-index 0 --role-count 1

Parameters (the scenario's role ``args``): :class:`AcoRoleParams`, checked when the scenario
loads, with ``check_run`` (the world must have ``start`` and ``goal`` zones, the start zone must
hold the fleet). ``run_metrics(env, report)`` computes Sec. 3.5's PQ, MC, AD, FT, FC and CF
(Eqs. 4-10) from the vehicles' metrics.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d

from companion.net.radio import Radio, open_radio
from companion.offboard_path import FollowParams, PathFollower
from companion.planning.aco.metrics import (
    TIME_FRAME_S,
    average_divergence,
    cost_function,
    flight_time,
    formation_change,
    mission_completion,
    path_quality,
)
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import finish, parser, return_after_failure, run_flight, scenario_env
from companion.swarm.aco import TOPIC, AcoProgram, AcoRoleParams, Peer, aco_params, arena
from companion.swarm.vehicle import Sensed
from companion.telemetry_waits import connect, first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock

PARAMS = AcoRoleParams
"""The dataclass of this program's ``args`` (checked when ``swarmsitl run`` loads a scenario)."""
DEFAULT_ORIGIN = (47.397742, 8.545594, 488.0)
"""World origin if none is given (swarmsitl's default), lat, lon (deg), AMSL (m)."""
PAPER_DIAMETER_M = 0.5
"""A vehicle's diameter when the fleet entry gives none, m (seed 001's UAVs, Sec. 4.1)."""
PEER_STALE_S = 1.0
"""A peer whose last message is older than this is no longer sensed, s (ten decisions: a
landed or silent vehicle's last position does not linger)."""
GIVE_UP_RESERVE_S = 30.0
"""A program still flying this long before the run's ``duration_s`` lands where it is, s (one
already landing goes on landing)."""
WAIT_WALL_S = 60.0
"""Wall-clock bound of a wait on the vehicle's clock (telemetry that stops), s."""
LAND_WAIT_S = 60.0
"""Simulated seconds a landing may take before it counts as failed, s."""


def _log(name: str, **data: Any) -> None:
    print(f"[aco_swarm] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


@dataclass(frozen=True)
class LocalFrame:
    """The autopilot's local NED (LOCAL_POSITION_NED, offboard setpoints) in world ENU.

    The local frame's origin is the EKF origin; ``origin_enu_m`` is where that lies in the world
    frame, up counted from the ground under home (home is at up 0, as in the swarm engine).
    """

    origin_enu_m: tuple[float, float, float]
    """World (east, north, up) of local NED (0, 0, 0), m."""

    @classmethod
    def at_rest(
        cls, world_en_m: tuple[float, float], local_ned_m: tuple[float, float, float]
    ) -> LocalFrame:
        """The frame from one position on the ground: world (east, north), local (n, e, d)."""
        n, e, d = (float(v) for v in local_ned_m)
        return cls((float(world_en_m[0]) - e, float(world_en_m[1]) - n, d))

    def to_enu(self, ned_m: np.ndarray) -> np.ndarray:
        """World ENU (3,) of a local NED point (up above the ground under home)."""
        n, e, d = (float(v) for v in ned_m)
        o = self.origin_enu_m
        return np.array([e + o[0], n + o[1], -d + o[2]])

    @staticmethod
    def velocity_to_ned(enu_m_s: np.ndarray) -> np.ndarray:
        """NED (3,) of an ENU velocity."""
        x, y, z = (float(v) for v in enu_m_s)
        return np.array([y, x, -z])


def diameters(env: ScenarioEnv) -> tuple[float, dict[int, float]]:
    """This vehicle's diameter and its role's by role index, m (``SWARMSITL_FLEET``).

    A missing fleet or ``diameter_m``: :data:`PAPER_DIAMETER_M`.
    """
    own = env.fleet_entry or {}
    by_index = {
        int(e["role_index"]): float(e.get("diameter_m") or PAPER_DIAMETER_M)
        for e in env.fleet or ()
        if e.get("role") == env.role
    }
    return float(own.get("diameter_m") or PAPER_DIAMETER_M), by_index


class ObstacleSensor:
    """Seed 001's detection within R_s (Eq. 14) on the full stack: idealised and exact.

    Stands for UTSim's detection (module docstring): the world's solids where they are at
    ``now_s`` (static, and moving ones by ``worlds.model.motion_centers`` through
    :class:`worlds.solid_set.SolidSet`), and the peers in :attr:`peers` as their messages put
    them. What it returns matches the swarm engine's ``sense``: the nearest point of a solid (its
    velocity), a peer's centre; the clearance from this vehicle's sphere, nearest first.
    """

    def __init__(
        self, world: Any, diameter_m: float, peer_diameters_m: Mapping[int, float]
    ) -> None:
        from worlds.solid_set import SolidSet

        self.solids = SolidSet(world.solids)
        self.radius_m = diameter_m / 2.0
        self.peer_radii_m = {k: d / 2.0 for k, d in peer_diameters_m.items()}
        self.peers: Mapping[str, Peer] = {}
        """The other vehicles by node id as last heard (the program's ``AcoProgram.peers``)."""

    def sense(self, here_enu_m: np.ndarray, now_s: float, radius_m: float) -> list[Sensed]:
        """What lies within ``radius_m`` of this vehicle's body at ``now_s``, nearest first."""
        me = np.asarray(here_enu_m, dtype=float)
        out: list[Sensed] = []
        for name, peer in self.peers.items():
            if now_s - peer.time_s > PEER_STALE_S:
                continue
            p = peer.at(now_s)
            r = self.peer_radii_m.get(peer.index, PAPER_DIAMETER_M / 2.0)
            d = math.dist(p, me) - self.radius_m - r
            if d <= radius_m:
                v = tuple(float(c) for c in peer.velocity)
                out.append(Sensed("vehicle", name, tuple(float(c) for c in p), v, d))
        if len(self.solids):
            _, ks, closest = self.solids.near(me[None, :], radius_m + self.radius_m, now_s)
            if len(ks):
                velocity = self.solids.velocities_at(now_s)
                for k, c in zip(ks, closest, strict=True):
                    d = math.dist(c, me) - self.radius_m
                    v = tuple(float(x) for x in velocity[k])
                    out.append(Sensed("solid", self.solids.names[k], tuple(map(float, c)), v, d))
        out.sort(key=lambda x: x.distance_m)
        return out


class MavsdkVehicle:
    """The vehicle as :class:`AcoProgram` commands and observes it on the full stack.

    The :class:`~companion.swarm.aco.AcoVehicle` of the MAVSDK adapter. Telemetry goes in
    (:meth:`see_position`, :meth:`see_armed`, :meth:`see_time`); commands are queued for the
    MAVSDK loop (:meth:`take_commands`: ``("takeoff", height)``, ``("offboard",)``,
    ``("land",)``), and :meth:`setpoint` is what to stream in Offboard now. World ENU, m; up
    above home.
    """

    def __init__(
        self,
        home_enu_m: np.ndarray,
        priority: int,
        sensor: ObstacleSensor,
        follow: FollowParams | None = None,
    ) -> None:
        self._home = np.array([home_enu_m[0], home_enu_m[1], 0.0], dtype=float)
        self.priority = int(priority)
        self.sensor = sensor
        self.follow = FollowParams() if follow is None else follow
        self._position = self._home.copy()
        self._now_s = 0.0
        self._commands: list[tuple[Any, ...]] = []
        self._climb_to_m: float | None = None
        self._path: PathFollower | None = None
        self._velocity: np.ndarray | None = None
        """The velocity held (ENU m/s) while not on a path."""
        self._offboard = False
        self._landing = False
        self._armed_seen = False
        self._lost = False

    @property
    def home_enu_m(self) -> np.ndarray:
        """(3,) where it took off: world east, north, m; 0 up."""
        return self._home.copy()

    @property
    def position_enu_m(self) -> np.ndarray:
        """(3,) the latest estimated position, world ENU, m (up above home)."""
        return self._position.copy()

    @property
    def airborne(self) -> bool:
        """Not down: armed since the take-off command (False once disarmed after arming)."""
        return not self._lost

    @property
    def path_index(self) -> int:
        """Index of the waypoint of the last path being flown to (0 before any path)."""
        return 0 if self._path is None else self._path.index

    @property
    def path_done(self) -> bool:
        """Climbed to the take-off height, or at the path's last waypoint.

        False while holding a velocity.
        """
        if self._velocity is not None:
            return False
        if self._path is not None:
            return self._path.done(self._position)
        if self._climb_to_m is not None:
            return bool(self._position[2] >= self._climb_to_m - self.follow.height_tolerance_m)
        return True

    def see_time(self, now_s: float) -> None:
        """The vehicle's clock, s (what the sensor places the moving solids by)."""
        self._now_s = float(now_s)

    def see_position(self, position_enu_m: np.ndarray) -> None:
        """A position estimate, world ENU m (passes the path's waypoints as they are reached)."""
        self._position[:] = position_enu_m
        if self._path is not None and self._velocity is None:
            self._path.see(self._position)

    def see_armed(self, armed: bool) -> None:
        """An armed state; disarmed after it was seen armed: the vehicle is down."""
        if armed:
            self._armed_seen = True
        elif self._armed_seen:
            self._lost = True

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        """Arm and climb to ``height_m`` above home (at the autopilot's MPC_TKO_SPEED)."""
        self._climb_to_m = float(height_m)
        self._commands.append(("takeoff", float(height_m)))

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly through the waypoints at ``speed_m_s`` in Offboard, stopping at the last."""
        self._path = PathFollower(waypoints_enu_m, speed_m_s, self._position, self.follow)
        self._velocity = None
        self._start_offboard()

    def set_velocity(self, velocity_enu_m_s: np.ndarray) -> None:
        """Hold this velocity (m/s) in Offboard until the next command."""
        self._velocity = np.asarray(velocity_enu_m_s, dtype=float).copy()
        self._start_offboard()

    def land(self) -> None:
        """Leave Offboard, descend where it is, touch down, disarm."""
        self._landing = True
        self._commands.append(("land",))

    def sense(self, radius_m: float) -> list[Sensed]:
        """What the :class:`ObstacleSensor` sees within ``radius_m`` now."""
        return self.sensor.sense(self._position, self._now_s, radius_m)

    def _start_offboard(self) -> None:
        if not self._offboard:
            self._offboard = True
            self._commands.append(("offboard",))

    @property
    def offboard(self) -> bool:
        """Offboard has been asked for (the first path or held velocity)."""
        return self._offboard

    def setpoint(self) -> np.ndarray | None:
        """The velocity setpoint to stream now, ENU m/s: the path's, or the one held.

        None: not in Offboard, or landing.
        """
        if not self._offboard or self._landing:
            return None
        if self._velocity is not None:
            return self._velocity.copy()
        if self._path is not None:
            return self._path.velocity(self._position)
        return None

    def take_commands(self) -> list[tuple[Any, ...]]:
        """The commands queued since the last call, oldest first."""
        out, self._commands = self._commands, []
        return out


def full_stack_params(params: AcoRoleParams, top_speed_m_s: float) -> AcoRoleParams:
    """The role's parameters as a real multicopter flies them.

    The speed at most the autopilot's ``MPC_XY_VEL_MAX``.
    """
    return dataclasses.replace(params, speed_m_s=min(params.speed_m_s, top_speed_m_s))


def _mavsdk() -> tuple[Any, Any]:
    """MAVSDK-Python's classic asyncio API: ``System``, ``VelocityNedYaw``.

    ``mavsdk_grpc``, else ``mavsdk`` (< 4).
    """
    try:
        from mavsdk_grpc import System
        from mavsdk_grpc.offboard import VelocityNedYaw
    except ImportError:
        from mavsdk import System
        from mavsdk.offboard import VelocityNedYaw
    return System, VelocityNedYaw


def yaw_deg(q: Any) -> float:
    """Heading of an attitude quaternion (body FRD to NED, ``w, x, y, z``), deg from north."""
    return math.degrees(
        math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    )


async def fly(env: ScenarioEnv, params: AcoRoleParams) -> dict[str, tuple[Any, str]]:
    """Take off, plan and fly the path with avoidance (and formation), land; the metrics."""
    if env.world is None:
        raise ValueError("the aco_swarm role needs the run's world (arena_aco)")
    world = arena(str(env.world))  # a bad world fails before connecting
    origin = env.origin or DEFAULT_ORIGIN
    system, velocity_ned_yaw = _mavsdk()
    clock = VehicleClock()
    drone = system(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    vehicle: MavsdkVehicle | None = None
    frame: LocalFrame | None = None
    radio: Radio | None = None
    heading = [0.0]
    flying = False
    gave_up = False

    async def attitudes() -> None:
        async for q in drone.telemetry.attitude_quaternion():
            clock.feed(q.timestamp_us)
            heading[0] = yaw_deg(q)

    async def positions() -> None:
        async for pv in drone.telemetry.position_velocity_ned():
            if vehicle is not None and frame is not None:
                p = pv.position
                vehicle.see_position(frame.to_enu((p.north_m, p.east_m, p.down_m)))

    async def armed_states() -> None:
        async for armed in drone.telemetry.armed():
            if vehicle is not None:
                vehicle.see_armed(armed)

    async def stream(yaw: float) -> None:
        """Send the vehicle's velocity setpoint now (MAVSDK repeats the last one meanwhile)."""
        assert vehicle is not None
        velocity = vehicle.setpoint()
        if velocity is not None:
            vn, ve, vd = LocalFrame.velocity_to_ned(velocity)
            await drone.offboard.set_velocity_ned(velocity_ned_yaw(vn, ve, vd, yaw))

    try:
        _log("connecting", url=env.mavlink_url, grpc_port=env.grpc_port)
        await connect(drone, env.mavlink_url, env.grpc_port)
        tasks.append(asyncio.create_task(attitudes()))
        await clock.wait_started(WAIT_WALL_S)
        await wait_position_ok(drone, clock)
        top_speed = await drone.param.get_param_float("MPC_XY_VEL_MAX")
        if params.speed_m_s > top_speed:
            _log("speed_capped", speed_m_s=top_speed, asked_m_s=params.speed_m_s)
        params = full_stack_params(params, top_speed)
        here = await first(drone.telemetry.position())
        local = (await first(drone.telemetry.position_velocity_ned())).position
        e, n, _ = pymap3d.geodetic2enu(here.latitude_deg, here.longitude_deg,
                                       here.absolute_altitude_m, *origin)  # fmt: skip
        frame = LocalFrame.at_rest((e, n), (local.north_m, local.east_m, local.down_m))
        own_d, peer_d = diameters(env)
        sensor = ObstacleSensor(world, own_d, peer_d)
        vehicle = MavsdkVehicle(np.array([e, n, 0.0]), env.priority, sensor)
        tasks += [asyncio.create_task(positions()), asyncio.create_task(armed_states())]
        radio = open_radio(TOPIC, _log)
        program = AcoProgram(
            dataclasses.replace(env, params=dataclasses.asdict(params)), vehicle, radio
        )
        sensor.peers = program.peers  # the vehicles the radio brought: the program's table
        await drone.action.set_return_to_launch_altitude(params.altitude_m)
        give_up_s = (env.duration_s or math.inf) - GIVE_UP_RESERVE_S
        _log("ready", vehicle_time_s=clock.now_s, priority=vehicle.priority,
             home_enu_m=np.round(vehicle.home_enu_m, 2).tolist(),
             target_enu_m=np.round(program.target, 2).tolist(),
             waypoints=len(program.waypoints), path_length_m=round(program.path_length_m, 1),
             plan_ms=round(program.plan_ms, 1), speed_m_s=params.speed_m_s)  # fmt: skip
        next_s = clock.now_s
        yaw = 0.0
        while True:
            now = clock.now_s
            vehicle.see_time(now)
            phase, divergences = program.phase, program.divergences
            program.decide(now)
            if program.phase != phase or program.divergences != divergences:
                _log("decision", vehicle_time_s=round(now, 2), phase=program.phase,
                     waypoint=program.index, divergences=program.divergences,
                     holds=program.holds,
                     position_enu_m=np.round(vehicle.position_enu_m, 2).tolist())  # fmt: skip
            for command in vehicle.take_commands():
                if command[0] == "takeoff":
                    await drone.action.set_takeoff_altitude(command[1])
                    await drone.action.arm()
                    await drone.action.takeoff()
                    flying = True
                elif command[0] == "offboard":
                    yaw = heading[0]  # fly the path at the heading it took off with
                    await stream(yaw)
                    await drone.offboard.start()
                elif command[0] == "land":
                    if vehicle.offboard:
                        await drone.offboard.stop()
                    await drone.action.land()
            await stream(yaw)
            if program.done:
                break
            if now >= give_up_s and program.phase != "land":  # a landing is left to end
                _log("giving_up", vehicle_time_s=round(now, 2), phase=program.phase)
                gave_up = True
                break
            next_s = max(next_s + params.decision_period_s, now)
            await clock.sleep(next_s - now, WAIT_WALL_S)
        radio.close()  # stop talking: landed, lost, or giving up
        if program.phase == "down":
            _log("vehicle_lost", vehicle_time_s=round(clock.now_s, 2))
        elif gave_up:
            if vehicle.offboard:
                await drone.offboard.stop()
            await drone.action.land()
            await wait_for(drone.telemetry.armed(), lambda a: not a, LAND_WAIT_S,
                           "landing after giving up", clock)  # fmt: skip
        flying = False
        _log("ended", vehicle_time_s=round(clock.now_s, 2), phase=program.phase,
             messages_heard=radio.heard, divergences=program.divergences)  # fmt: skip
    except BaseException:
        if flying:
            await return_after_failure(drone, "aco_swarm")
        raise
    finally:
        if radio is not None:
            radio.close()
        for t in tasks:
            t.cancel()
        drone._stop_mavsdk_server()
    metrics = program.metrics()
    if gave_up:
        metrics["phase"] = ("timeout", "name")
    return metrics


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> AcoProgram:
    """This role behind the swarm engine's kinematic vehicle (its ``AcoVehicle``)."""
    return AcoProgram(env, vehicle, node)


def run_metrics(env: ScenarioEnv, report: dict[str, Any]) -> dict[str, tuple[Any, str]]:
    """Seed 001's figures for the run (Sec. 3.5, Eqs. 4-10), in the paper's mixed units.

    Over the role's vehicles (those whose metrics carry ``reached``): PQ (Eq. 4, %) over the
    vehicles that reached their target (a vehicle that did not has no complete TotalDist); MC
    (Eq. 5, %); AD (Eq. 6, divergences per drone, all vehicles); FT (Eq. 7) with T the makespan
    from the first departure (the earliest mission start) to the last arrival, over 60 s (None
    unless every vehicle reached); FC (Eq. 8, %, option 2 only) from each vehicle's
    ``avg_dist_change_m`` and the role's ``threshold_m``; CF by Eq. 9 (option 1) or Eq. 10
    (option 2) when all its terms exist; and the mean plan wall time (ms).
    """
    params = aco_params(env)
    rows = []
    for veh in report["vehicles"].values():
        companion = veh.get("companion") or {}
        if "reached" in companion:
            rows.append({k: v["value"] for k, v in companion.items()})
    reached = [bool(r["reached"]) for r in rows]
    done = [r for r in rows if r["reached"] and r["total_dist_m"]]
    pq = path_quality([r["min_dist_m"] for r in done], [r["total_dist_m"] for r in done])
    mc = mission_completion(reached)
    ad = average_divergence([r["divergences"] for r in rows])
    ft = None
    if rows and all(reached):
        makespan = max(r["arrived_s"] for r in rows) - min(r["mission_start_s"] for r in rows)
        ft = flight_time(makespan, TIME_FRAME_S)
    fc = None
    if params.option == 2:
        changes = [r["avg_dist_change_m"] for r in rows if r["avg_dist_change_m"] is not None]
        fc = formation_change(changes, params.threshold_m) if changes else None
    cf = None
    if ft is not None and math.isfinite(pq) and (params.option == 1 or fc is not None):
        cf = cost_function(pq, ft, ad, mc, fc if params.option == 2 else None)
    plan = [r["plan_ms"] for r in rows if r["plan_ms"] is not None]

    def num(x: float | None) -> float | None:
        return None if x is None or not math.isfinite(x) else round(float(x), 4)

    return {
        "pq": (num(pq), "%"),
        "mc": (num(mc), "%"),
        "ad": (num(ad), "count"),
        "ft": (num(ft), "ratio"),
        "fc": (num(fc), "%"),
        "cf": (num(cf), "score"),
        "plan_ms_mean": (num(sum(plan) / len(plan)) if plan else None, "ms"),
        "divergences": (sum(r["divergences"] for r in rows), "count"),
        "reached": (sum(reached), "count"),
    }


def main(argv: list[str] | None = None) -> None:
    """Read the environment and options, fly, write result.json; exit 0, or 1 on a failure."""
    ap = parser(__doc__, "src/worlds/examples/arena_aco.yaml", '{"option": 2}')
    args = ap.parse_args(argv)

    def fly_with_params(env: ScenarioEnv) -> Mapping[str, tuple[Any, str]]:
        return run_flight(fly(env, aco_params(env)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
