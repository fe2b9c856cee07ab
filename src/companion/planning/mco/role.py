"""The MCO role's inputs from its environment: the workspace, the take-off point, the fleet.

Shared by the role's two adapters (``companion.scripts.mco_plan`` with MAVSDK,
``companion.swarm.mco`` at swarm scale): both build the same plan from the same inputs, so that
every vehicle of a run flies its own part of one plan. The plan is computed once per process
(``cached_plan``): at swarm scale every vehicle of a run lives in one process.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from companion.planning.mco.auction import Bidder
from companion.planning.mco.plan import McoParams, MissionPlan, plan_mission
from companion.planning.mco.workspace import Workspace
from companion.role_params import params_from_mapping
from companion.scenario_env import ScenarioEnv

TAKEOFF_M = 20.0
"""Height of the take-off, m (at most the survey height). The mission's first item climbs on over
home to the survey height (PX4 bounds MIS_TAKEOFF_ALT, the emulation at 80 m, and takes off at
MPC_TKO_SPEED, 1.5 m/s: a coarse survey's 84 m is a climb at MPC_Z_V_AUTO_UP instead); its last
comes home down to this height plus ``altitude_step_m`` per role index."""
START_SPREAD_S = 3.0
"""How far apart in time the fleet's take-offs may be, s (the companions start together)."""
TRAITS = ("flight_time_s", "decision", "communication")
"""Fleet-file traits a vehicle bids with (P8: flight time, decision capacity, communication)."""


def mco_params(env: ScenarioEnv) -> McoParams:
    """The role's ``args`` as McoParams (unknown keys and bad values name themselves)."""
    return params_from_mapping(McoParams, env.params)


def fleet_bidders(
    fleet: Sequence[Mapping[str, Any]] | None, role: str, count: int
) -> tuple[Bidder, ...]:
    """The bidders of the vehicles of ``role`` from the fleet file (``ScenarioEnv.fleet``).

    A trait a vehicle's entry does not give is 1 for every vehicle (a homogeneous fleet scores 3
    on it, Eq. (2), seed 004). Without a fleet description: ``count`` vehicles 1..count.
    """
    if not fleet:
        return tuple(Bidder(v, 1.0, 1.0, 1.0) for v in range(1, count + 1))
    out = []
    for entry in fleet:
        if entry.get("role") != role:
            continue
        traits = entry.get("traits") or {}
        values = []
        for name in TRAITS:
            value = float(traits.get(name, 1.0))
            if not np.isfinite(value):
                raise ValueError(f"fleet: vehicle {entry.get('vehicle')}: trait {name} is {value}")
            values.append(value)
        out.append(Bidder(int(entry["vehicle"]), *values))
    return tuple(out)


def workspace_of(world: Any) -> tuple[Workspace, np.ndarray]:
    """The workspace of a built world and its take-off point p0 (its launch area's centre)."""
    from worlds.launch import default_area

    area = default_area(world)
    return Workspace.from_world(world), np.array(area.center_enu_m[:2], dtype=float)


@functools.lru_cache(maxsize=8)
def cached_plan(
    world_path: str, params: McoParams, fleet: tuple[Bidder, ...], seed: int
) -> MissionPlan:
    """The run's plan, computed once per process for the same inputs."""
    import worlds

    world = worlds.build(worlds.load_world(Path(world_path)))
    workspace, home = workspace_of(world)
    return plan_mission(workspace, params, fleet, home, np.random.default_rng(seed))


def plan_for(env: ScenarioEnv, params: McoParams) -> MissionPlan:
    """The plan this vehicle's run flies (ValueError without a world)."""
    if env.world is None:
        raise ValueError("the MCO role needs the run's world (SWARMSITL_WORLD): the workspace")
    bidders = fleet_bidders(env.fleet, env.role, env.role_count)
    return cached_plan(str(env.world), params, bidders, env.seed)


def own_flight_time_s(env: ScenarioEnv) -> float:
    """This vehicle's ``flight_time_s`` trait from the fleet file (inf when not given)."""
    for entry in env.fleet or ():
        if int(entry.get("vehicle", -1)) == env.vehicle:
            return float((entry.get("traits") or {}).get("flight_time_s", math.inf))
    return math.inf


def survey_height_m(params: McoParams, role_index: int) -> float:
    """Height vehicle ``role_index`` of the role surveys at: the camera's, plus its step, m."""
    return params.flight_altitude_m + role_index * params.altitude_step_m


def home_height_m(params: McoParams, role_index: int) -> float:
    """Height the tour comes home at: TAKEOFF_M plus the role index's step, at most the survey's."""
    return min(survey_height_m(params, role_index), TAKEOFF_M + role_index * params.altitude_step_m)


def departure_hold_s(
    params: McoParams, role_index: int, role_count: int, climb_m_s: float
) -> float:
    """How long a vehicle holds over its home at survey height before it leaves, s.

    Until the vehicles flying higher (role index above its own) have climbed past its height: a
    vehicle leaving the shared take-off point must not cross a column another still climbs in.
    """
    step = params.altitude_step_m
    if step <= 0.0:
        return 0.0
    higher = role_count - 1 - role_index
    return higher * (step / climb_m_s + START_SPREAD_S)
