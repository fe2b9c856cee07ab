"""Caravan companion (seed 003): decentralised task allocation of a degraded fleet on a task map.

Each vehicle runs one agent of the allocator its role's ``algorithm`` names (CarA/ICF, GBAA or
ICA; ``companion.planning.caravan``), exchanges its consensus messages with the vehicles in radio
range, flies to the task it holds, completes it on arrival, and lands at home when every task is
known completed. Both adapters run the very same decisions, :class:`CaravanProgram`
(:mod:`companion.swarm.caravan`): take-off to ``altitude_m + altitude_step_m * role_index``, then
every decision period messages in, Eq. (26) bids from where the vehicle is (lattice travel times,
``TaskGraph``), one allocator step, the arrival check, its message out, and a new flight target
when its task changed.

* Swarm fidelity (``swarm_program``): in-process behind the kinematic adapter, one decision per
  engine decision (``swarm.decision_hz``), lattice routes.
* Full stack (``main``, ``python -m companion.scripts.caravan``): this program, MAVSDK only, as it
  runs on a Raspberry Pi beside a PX4. :class:`MavsdkVehicle` gives ``CaravanProgram`` the
  vehicle it commands (telemetry in, MAVSDK commands out) and
  :class:`~companion.net.radio.Radio` its messages (``companion.net``:
  ``SWARMSITL_NET``/``SWARMSITL_NODE``, the scenario's ``node:`` groups; the topic ``caravan`` to
  every other node). One decision every ``decision_period_s`` (default
  0.2 s, the 5 Hz of the seed-003 experiment) of the *vehicle's* clock (its telemetry stamps:
  the simulation's time under swarmsitl, so a lockstep run steps alike however fast it goes).
  It flies straight to the task it holds (``action.goto_location`` at its own height, then
  ``action.set_current_speed(speed_m_s)``; PX4's MPC_XY_CRUISE cannot go below 3 m/s): at this
  fidelity the lattice shapes the bids, not the flight (the swarm adapter's vehicles cut the
  lattice's corners too). A real multicopter on
  GNSS does not settle within the swarm's 0.25 m, so a task counts as reached within
  ``max(arrive_tolerance_m, FULL_STACK_ARRIVE_M)`` (1 m) horizontally. When every task is known
  completed it flies home at its own height and lands there (the staggered heights keep the
  transits apart). A vehicle found disarmed after it had armed (a crash: PX4's flight
  termination disarms; a forced landing) ends the program quietly: it stops acting and sending,
  writes its result and exits 0. Close to the run's end (``duration_s`` less
  ``GIVE_UP_RESERVE_S``) a program still at work returns to launch and ends (phase ``timeout``).

The allocators compare times across vehicles (Eq. 22's liveness, relayed): the fleet's clocks
must agree. Under swarmsitl every autopilot's clock is the simulation's; on real vehicles
synchronise the companions' clocks (GNSS time) and feed the allocator that.

``result.json``: ``CaravanProgram.metrics()``, the same names and units at both fidelities:
``algorithm``, ``completions`` ([task, time s] of the tasks it completed, vehicle time, the
simulation's time under swarmsitl), ``tasks_completed``, ``tasks_assigned``, ``tasks_released``
(list), ``tasks_validated``, ``last_change_step``, ``steps``, ``duplicates``, ``start_xy`` (its
home, world ENU m), ``mission_start`` (s, when it had climbed) and ``phase``.

    python -m companion.scripts.caravan --world src/worlds/examples/taskmap.yaml \
        --params '{"algorithm": "icf", "speed_m_s": 3}' --role-index 0 --role-count 4

Parameters (the scenario's role ``args``): :class:`CaravanParams`. ``run_metrics(env, report)``
computes the run's seed-003 figures (optimality gap, convergence steps, execution time, ...) from
the vehicles' metrics and the world, at either fidelity.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import os
from collections.abc import Mapping
from typing import Any

import numpy as np
import pymap3d

from companion.net.radio import Radio, open_radio
from companion.planning.caravan.optimum import (
    achieved_score,
    optimal_score,
    optimality_gap,
    score_matrix,
)
from companion.planning.caravan.scores import CaravanParams
from companion.scenario_env import ScenarioEnv
from companion.scripts.program import finish, parser, return_after_failure, run_flight, scenario_env
from companion.swarm.caravan import TOPIC, CaravanProgram, caravan_params, task_map
from companion.telemetry_waits import connect, first, wait_for, wait_position_ok
from companion.vehicle_clock import VehicleClock

PARAMS = CaravanParams
"""The dataclass of this program's ``args`` (checked when ``swarmsitl run`` loads a scenario)."""
DEFAULT_ORIGIN = (47.397742, 8.545594, 488.0)
"""World origin if none is given (swarmsitl's default), lat, lon (deg), AMSL (m)."""
FULL_STACK_ARRIVE_M = 1.0
"""Least horizontal distance to a task that counts as reached on the full stack, m (a GNSS
multicopter holds a point to a few decimetres, not the swarm's 0.25 m)."""
CLIMBED_FRACTION = 0.9
"""The take-off is done at this fraction of the vehicle's height (as the other programs)."""
PATH_DONE_M = 0.3
"""Horizontal distance to a goto's target within which the flight there is done, m (the swarm
adapter's home tolerance, ``companion.swarm.caravan.HOME_TOLERANCE_M``: the program lands
within it)."""
GIVE_UP_RESERVE_S = 30.0
"""A program still at work this long before the run's ``duration_s`` returns to launch, s."""
WAIT_WALL_S = 60.0
"""Wall-clock bound of a wait on the vehicle's clock (telemetry that stops), s."""


def _log(name: str, **data: Any) -> None:
    print(f"[caravan] {name} {json.dumps(data, default=str) if data else ''}", flush=True)


class MavsdkVehicle:
    """The vehicle as :class:`CaravanProgram` commands and observes it, on the full stack.

    Telemetry goes in (:meth:`see_position`, :meth:`see_armed`), the program's commands are
    queued and carried out by the MAVSDK loop (:meth:`take_commands`): ``("takeoff", height)``,
    ``("goto", (east, north, height above home))``, ``("land",)``. Positions are world ENU, m,
    east and north from the geodetic position, up from the barometric height above home.
    """

    def __init__(self, home_enu_m: np.ndarray) -> None:
        self._home = np.array([home_enu_m[0], home_enu_m[1], 0.0], dtype=float)
        self._position = self._home.copy()
        self._commands: list[tuple[Any, ...]] = []
        self._climb_to_m: float | None = None
        self._target_xy: np.ndarray | None = None
        self._armed_seen = False
        self._lost = False

    @property
    def home_enu_m(self) -> np.ndarray:
        """(3,) where it took off: world east, north, m; 0 up (heights are above home)."""
        return self._home.copy()

    @property
    def position_enu_m(self) -> np.ndarray:
        """(3,) the latest estimated position: world east, north, height above home, m."""
        return self._position.copy()

    @property
    def airborne(self) -> bool:
        """Not lost: armed since the take-off command (False once disarmed after arming)."""
        return not self._lost

    @property
    def path_done(self) -> bool:
        """Climbed (after the take-off), or within PATH_DONE_M of the goto's target."""
        if self._target_xy is not None:
            return math.dist(self._position[:2], self._target_xy) <= PATH_DONE_M
        if self._climb_to_m is not None:
            return bool(self._position[2] >= CLIMBED_FRACTION * self._climb_to_m)
        return True

    def see_position(self, east_m: float, north_m: float, up_m: float) -> None:
        """A position estimate, world ENU m (up: above home)."""
        self._position[:] = (east_m, north_m, up_m)

    def see_armed(self, armed: bool) -> None:
        """An armed state; disarmed after it was seen armed: the vehicle is down."""
        if armed:
            self._armed_seen = True
        elif self._armed_seen:
            self._lost = True

    def takeoff(self, height_m: float, climb_m_s: float | None = None) -> None:
        """Arm and climb to ``height_m`` above home (the autopilot's climb rate)."""
        self._climb_to_m = float(height_m)
        self._commands.append(("takeoff", float(height_m)))

    def fly_path(self, waypoints_enu_m: np.ndarray, speed_m_s: float) -> None:
        """Fly straight to the path's last point (at the role's speed)."""
        end = np.asarray(waypoints_enu_m, dtype=float).reshape(-1, 3)[-1]
        self._target_xy = end[:2].copy()
        self._commands.append(("goto", tuple(float(c) for c in end)))

    def land(self) -> None:
        """Descend where it is, touch down, disarm."""
        self._commands.append(("land",))

    def take_commands(self) -> list[tuple[Any, ...]]:
        """The commands queued since the last call, oldest first."""
        out, self._commands = self._commands, []
        return out


def full_stack_params(params: CaravanParams, top_speed_m_s: float) -> CaravanParams:
    """The role's parameters as a real multicopter flies them.

    Its speed at most the autopilot's ``MPC_XY_VEL_MAX``; a task reached within at least
    FULL_STACK_ARRIVE_M.
    """
    return dataclasses.replace(
        params,
        speed_m_s=min(params.speed_m_s, top_speed_m_s),
        arrive_tolerance_m=max(params.arrive_tolerance_m, FULL_STACK_ARRIVE_M),
    )


def _mavsdk_system() -> Any:
    """MAVSDK-Python's classic asyncio ``System``: ``mavsdk_grpc``, else ``mavsdk`` (< 4)."""
    try:
        from mavsdk_grpc import System
    except ImportError:
        from mavsdk import System
    return System


async def fly(env: ScenarioEnv, params: CaravanParams) -> dict[str, tuple[Any, str]]:
    """Take off, allocate and fly the tasks, land (or end quietly when lost); the metrics."""
    if env.world is None:
        raise ValueError("the caravan role needs the run's world (a taskmap): the tasks")
    task_map(str(env.world))  # a world without tasks fails before connecting
    origin = env.origin or DEFAULT_ORIGIN
    clock = VehicleClock()
    drone = _mavsdk_system()(port=env.grpc_port)
    tasks: list[asyncio.Task] = []
    vehicle: MavsdkVehicle | None = None
    radio: Radio | None = None
    flying = False
    gave_up = False

    async def attitudes() -> None:
        async for q in drone.telemetry.attitude_quaternion():
            clock.feed(q.timestamp_us)

    async def positions() -> None:
        async for p in drone.telemetry.position():
            if vehicle is not None:
                e, n, _ = pymap3d.geodetic2enu(p.latitude_deg, p.longitude_deg,
                                               p.absolute_altitude_m, *origin)  # fmt: skip
                vehicle.see_position(e, n, p.relative_altitude_m)

    async def armed_states() -> None:
        async for armed in drone.telemetry.armed():
            if vehicle is not None:
                vehicle.see_armed(armed)

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
        home = await first(drone.telemetry.home())
        home_enu = pymap3d.geodetic2enu(home.latitude_deg, home.longitude_deg,
                                        home.absolute_altitude_m, *origin)  # fmt: skip
        vehicle = MavsdkVehicle(np.array(home_enu, dtype=float))
        tasks += [asyncio.create_task(positions()), asyncio.create_task(armed_states())]
        radio = open_radio(TOPIC, _log)
        program = CaravanProgram(
            dataclasses.replace(env, params=dataclasses.asdict(params)), vehicle, radio
        )
        await drone.action.set_return_to_launch_altitude(program.height_m)
        give_up_s = (env.duration_s or math.inf) - GIVE_UP_RESERVE_S
        _log("ready", vehicle_time_s=clock.now_s, agent=program.agent,
             height_m=program.height_m, home_enu_m=np.round(home_enu, 2).tolist(),
             tasks=len(program.tasks_xy), speed_m_s=params.speed_m_s)  # fmt: skip
        next_s = clock.now_s
        while True:
            now = clock.now_s
            phase, task = program.phase, program.allocator.task
            program.decide(now)
            if program.phase != phase or program.allocator.task != task:
                _log("decision", vehicle_time_s=round(now, 2), phase=program.phase,
                     task=program.allocator.task,
                     completed=[j for j, _ in program.allocator.stats.completed])  # fmt: skip
            for command in vehicle.take_commands():
                await _execute(drone, command, home, origin, params.speed_m_s)
                flying = flying or command[0] == "takeoff"
            if program.done:
                break
            if now >= give_up_s:
                _log("giving_up", vehicle_time_s=round(now, 2), phase=program.phase)
                gave_up = True
                break
            next_s = max(next_s + params.decision_period_s, now)
            await clock.sleep(next_s - now, WAIT_WALL_S)
        radio.close()  # stop talking: landed, lost, or giving up
        if program.phase == "down":
            flying = False
            _log("vehicle_lost", vehicle_time_s=round(clock.now_s, 2))
        elif gave_up:
            await drone.action.return_to_launch()
            await wait_for(drone.telemetry.armed(), lambda a: not a, GIVE_UP_RESERVE_S,
                           "landing after return to launch", clock)  # fmt: skip
        flying = False
        _log("ended", vehicle_time_s=round(clock.now_s, 2), phase=program.phase,
             messages_heard=radio.heard)  # fmt: skip
    except BaseException:
        if flying:
            await return_after_failure(drone, "caravan")
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


async def _execute(
    drone: Any,
    command: tuple[Any, ...],
    home: Any,
    origin: tuple[float, float, float],
    speed_m_s: float,
) -> None:
    """Carry out one of :class:`MavsdkVehicle`'s commands.

    East and north are world ENU at ``origin``; heights are above ``home`` (MAVSDK's home).
    """
    kind = command[0]
    if kind == "takeoff":
        await drone.action.set_takeoff_altitude(command[1])
        await drone.action.arm()
        await drone.action.takeoff()
    elif kind == "goto":
        east, north, up = command[1]
        lat, lon, _ = pymap3d.enu2geodetic(east, north, 0.0, *origin)
        await drone.action.goto_location(lat, lon, home.absolute_altitude_m + up, math.nan)
        await drone.action.set_current_speed(speed_m_s)  # after it: PX4 applies it to the goto
    elif kind == "land":
        await drone.action.land()


def swarm_program(env: ScenarioEnv, vehicle: Any, node: Any) -> Any:
    """This role behind the swarm-scale engine's kinematic adapter (``companion.swarm.caravan``)."""
    from companion.swarm.caravan import CaravanProgram

    return CaravanProgram(env, vehicle, node)


def run_metrics(env: ScenarioEnv, report: dict[str, Any]) -> dict[str, tuple[Any, str]]:
    """Seed 003's figures for a whole run, from the report's per-vehicle metrics and the world.

    A task's completion time T_j is its first completion, counted from the completing vehicle's
    ``mission_start`` (when it had climbed: seed 003's agents start in the plane at time 0);
    ``optimality_gap`` compares J = sum a exp(-lambda T_j) over completed tasks with J*, the best
    single assignment (Eq. 1) from the vehicles' start points flying straight at the role's
    speed: full information, no loss, no lattice detour (the vehicles cut the lattice's corners,
    so lattice times would let a run beat its "optimum"); J can still exceed J* when a vehicle
    that finished its task takes a second one sooner than its holder would reach it (Eq. 14),
    which no single assignment expresses (``companion.planning.caravan.optimum``);
    ``execution_time`` is Eq. (29), the latest T_j (None if no task was completed);
    ``completed_by`` names, per task, the vehicle of its first completion (``vehicle3``; None:
    not completed), a list that sweeps' tables leave out (they keep numbers only).
    """
    if env.world is None:
        raise ValueError("run_metrics: the run's world (a taskmap) is needed")
    params = caravan_params(env)
    tasks_xy, _, _ = task_map(str(env.world))
    m = len(tasks_xy)
    rows, names = [], []
    for name in sorted(report["vehicles"], key=lambda s: int(s.removeprefix("vehicle"))):
        companion = report["vehicles"][name].get("companion") or {}
        if "algorithm" in companion:
            rows.append({k: v["value"] for k, v in companion.items()})
            names.append(name)
    first = np.full(m, np.nan)
    count = np.zeros(m, dtype=int)
    by: list[str | None] = [None] * m
    for name, r in zip(names, rows, strict=True):
        start = r.get("mission_start") or 0.0
        for j, t in r["completions"]:
            count[j] += 1
            t_j = max(float(t) - start, 0.0)
            if not t_j >= first[j]:  # the first completion (nan: none yet)
                first[j], by[j] = t_j, name
    starts = np.array([r["start_xy"] for r in rows], dtype=float).reshape(-1, 2)
    j_star = optimal_score(score_matrix(None, starts, tasks_xy, params)) if len(rows) else 0.0
    j = achieved_score(first, params)
    done = np.isfinite(first)
    released = set().union(*(set(r["tasks_released"]) for r in rows)) if rows else set()
    return {
        "optimality_gap": (optimality_gap(j_star, j) if j_star > 0 else None, "fraction"),
        "score": (round(j, 3), "score"),
        "optimal_score": (round(j_star, 3), "score"),
        "convergence_steps": (max((r["last_change_step"] for r in rows), default=0), "count"),
        "execution_time": (float(first[done].max()) if done.any() else None, "s"),
        "tasks_assigned": (sum(r["tasks_assigned"] for r in rows), "count"),
        "tasks_released": (len(released), "count"),
        "tasks_validated": (int(done.sum()), "count"),
        "tasks_total": (m, "count"),
        "tasks_completed_twice": (int((count >= 2).sum()), "count"),
        "completed_by": (by, "name"),
    }


def main(argv: list[str] | None = None) -> None:
    """Read the environment and options, fly, write result.json; exit 0, or 1 on a failure."""
    ap = parser(__doc__, "src/worlds/examples/taskmap.yaml", '{"algorithm": "icf"}')
    args = ap.parse_args(argv)

    def fly_with_params(env: ScenarioEnv) -> Mapping[str, tuple[Any, str]]:
        return run_flight(fly(env, caravan_params(env)))

    finish(fly_with_params, lambda: scenario_env(args, os.environ), _log)


if __name__ == "__main__":
    main()
