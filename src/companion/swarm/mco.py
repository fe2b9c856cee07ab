"""The MCO role (``companion.scripts.mco_plan``) behind the kinematic adapter.

The same decisions as the MAVSDK program, in the same order: compute the run's plan
(``companion.planning.mco.role.plan_for``, the same plan on every vehicle), take off to its
survey height, hold over home until the vehicles flying higher have climbed past
(``departure_hold_s``), fly this vehicle's tour out of the take-off point and back as one path
(the mission), coming home down to its own low height (``home_height_m``), and land where it
took off. Links, battery and active vehicles are measured by the engine.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from companion.net.node import Node
from companion.planning.mco.role import (
    departure_hold_s,
    home_height_m,
    mco_params,
    own_flight_time_s,
    plan_for,
    survey_height_m,
)
from companion.planning.mco.tours import straight_legs
from companion.scenario_env import ScenarioEnv
from companion.swarm.vehicle import SwarmVehicle


class McoProgram:
    """One vehicle's MCO task at swarm scale (see the module docstring)."""

    def __init__(self, env: ScenarioEnv, vehicle: SwarmVehicle, node: Node | None) -> None:
        self.env = env
        self.vehicle = vehicle
        self.params = mco_params(env)
        self.plan = plan_for(env, self.params)
        self.task = self.plan.task_of(env.vehicle)
        self.flight_time_s = own_flight_time_s(env)
        self.altitude_m = survey_height_m(self.params, env.role_index)
        self.phase = "takeoff"
        self.error: str | None = None
        self.landed_s = math.nan
        self.leave_s = math.nan

    @property
    def done(self) -> bool:
        """Landed after the flight."""
        return self.phase == "done"

    def decide(self, now_s: float) -> None:
        """The flight phase's next step."""
        v = self.vehicle
        if self.phase == "takeoff":
            v.takeoff(self.altitude_m, self.params.climb_m_s)
            self.phase = "climb"
        elif self.phase == "climb" and v.path_done:
            env = self.env
            hold = departure_hold_s(self.params, env.role_index, env.role_count,
                                    self.params.climb_m_s)  # fmt: skip
            self.leave_s = now_s + hold  # as the MAVSDK program's first mission item holds
            self.phase = "hold"
        elif self.phase == "hold" and now_s >= self.leave_s:
            home = v.home_enu_m
            tour = np.vstack([home[None, :2], self.task.waypoints_xy_m, home[None, :2]])
            xy = straight_legs(tour)[1:]  # from where it hovers, corner to corner, home
            z = np.full((len(xy), 1), float(home[2]) + self.altitude_m)
            z[-1] = float(home[2]) + home_height_m(self.params, self.env.role_index)
            v.fly_path(np.hstack([xy, z]), self.params.speed_m_s)
            self.phase = "survey"
        elif self.phase == "survey" and v.path_done:
            v.land()
            self.phase = "land"
        elif self.phase == "land" and not v.airborne:
            self.landed_s = now_s
            self.phase = "done"

    def metrics(self) -> dict[str, tuple[Any, str]]:
        """The plan's numbers and this vehicle's task (its ``result.json`` at full fidelity)."""
        return task_metrics(self.plan, self.task, self.flight_time_s) | {
            "landed_at": (None if math.isnan(self.landed_s) else round(self.landed_s, 2), "s"),
        }


def task_metrics(plan: Any, task: Any, flight_time_s: float) -> dict[str, tuple[Any, str]]:
    """What both adapters report of the plan and of a vehicle's task.

    ``flight_time_s``: the vehicle's own flight time (its fleet trait); a task that needs more
    is counted in ``task_over_flight_time``: the auction's fallback gave it to this vehicle.
    """
    return {
        "role": (str(task.role), "name"),
        "is_master": (int(task.role == "master"), "count"),
        "sub_area": (task.sub_area, "index"),
        "task_waypoints": (len(task.waypoints_xy_m), "count"),
        "planned_path": (round(task.path_length_m, 2), "m"),
        "planned_flight_time": (round(task.flight_time_s, 2), "s"),
        "plan_waypoints": (plan.waypoints, "count"),
        "heterogeneity_std": (round(plan.heterogeneity_std_pct, 4), "%"),
        "auction_rounds": (plan.auction.rounds, "count"),
        "auction_fallbacks": (sum("fallback" in line for line in plan.auction.log), "count"),
        "task_over_flight_time": (int(task.flight_time_s > flight_time_s), "count"),
    }
