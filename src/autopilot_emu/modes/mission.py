"""Mission mode: one tick of the mission executor, and the feasibility check of a stored plan.

The executor (:mod:`autopilot_emu.mission.executor`) walks the items; this module feeds it the
tick's estimate and the acceptance parameters, and turns its leg into the position setpoint.
A landing leg ends in Land's descent once the vehicle is over the landing point.
"""

from __future__ import annotations

import numpy as np

from autopilot_emu import geodesy
from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.mission.executor import Leg, MissionExecutor, StepInput, Tolerances
from autopilot_emu.mission.feasibility import PlanContext, mission_feasibility
from autopilot_emu.mission.geofence import Fence
from autopilot_emu.mission.items import MissionItem
from autopilot_emu.modes.nav_types import (
    SEVERITY_CRITICAL,
    SEVERITY_INFO,
    SEVERITY_WARNING,
    Home,
    NavInput,
    Say,
)
from autopilot_emu.modes.takeoff import takeoff_height_m


def mission_leg(
    mission: MissionExecutor,
    nav: NavInput,
    landed: bool,
    home: Home,
    origin: np.ndarray,
    params: CommanderParams,
) -> Leg:
    """Advance the executor by one tick; its leg (``origin``: NED origin, lat, lon, alt AMSL)."""

    def to_ned(lat: float, lon: float, alt: float) -> np.ndarray:
        return geodesy.geodetic_to_ned(np.array([lat, lon, alt]), origin)

    return mission.step(
        StepInput(
            time_s=nav.time_s,
            position_ned_m=nav.position_ned_m,
            yaw_rad=nav.yaw_rad,
            landed=landed,
            home_alt_amsl_m=home.alt_amsl_m,
            tolerances=Tolerances(
                acceptance_radius_m=params.acceptance_radius_m,
                altitude_radius_m=params.altitude_radius_m,
                takeoff_alt_m=takeoff_height_m(params),
            ),
            to_ned=to_ned,
        )
    )


def take_events(
    mission: MissionExecutor,
    reached: list[int],
    commands: list[ComponentCommand],
    say: Say,
) -> float | None:
    """Move the executor's events out: items reached, camera commands, texts (to ``say``).

    Returns a speed change since the last tick (NaN: back to the default), or None.
    """
    reached.extend(mission.reached)
    mission.reached.clear()
    commands.extend(mission.component_commands)
    mission.component_commands.clear()
    for text in mission.texts:
        say(SEVERITY_INFO, text)
    mission.texts.clear()
    speed_m_s, mission.speed_m_s = mission.speed_m_s, None
    return speed_m_s


def over_landing_point(target: np.ndarray, nav: NavInput, params: CommanderParams) -> bool:
    """A landing leg may descend: the vehicle is within NAV_ACC_RAD of the landing point."""
    offset = float(np.hypot(*(target[:2] - nav.position_ned_m[:2])))
    return offset <= params.acceptance_radius_m


def mission_feasible(
    items: tuple[MissionItem, ...],
    home: Home | None,
    origin: np.ndarray | None,
    fence: Fence,
    params: CommanderParams,
    say: Say,
) -> bool:
    """PX4's feasibility check of a stored mission; announces why it is refused."""
    if not items:
        return False
    home_lla = None
    if home is not None and origin is not None:
        lat, lon, _ = geodesy.ned_to_geodetic(home.position_ned_m, origin)
        home_lla = (float(lat), float(lon), home.alt_amsl_m)
    result = mission_feasibility(
        items,
        PlanContext(
            home_lat_lon_alt=home_lla,
            fence=fence,
            max_hor_dist_m=params.fence_max_hor_dist_m,
            max_ver_dist_m=params.fence_max_ver_dist_m,
            dist_1wp_m=params.dist_1wp_m,
        ),
    )
    for warning in result.warnings:
        say(SEVERITY_WARNING, warning)
    if result.problem is not None:
        say(SEVERITY_CRITICAL, result.problem)
        return False
    return True
