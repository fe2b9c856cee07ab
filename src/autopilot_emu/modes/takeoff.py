"""Takeoff mode: the climb target, its completion, and the climb-rate ramp until lift-off.

As PX4's navigator Takeoff and mc_pos_control's takeoff state: the vehicle climbs straight up to
the requested altitude (NAV_TAKEOFF param7, AMSL) or to home + MIS_TAKEOFF_ALT, then holds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.estimator import GRAVITY_M_S2
from autopilot_emu.modes.nav_types import (
    SEVERITY_INFO,
    SEVERITY_WARNING,
    Home,
    NavInput,
    NavOutput,
    Say,
)

MIN_TAKEOFF_HEIGHT_M = 1.0
"""Lowest take-off height above the ground, m: a take-off to or below the ground (a NAV_TAKEOFF
with a low param7, MIS_TAKEOFF_ALT 0) would leave the vehicle "taking off" on the ground."""
REACHED_M = 0.3
"""Vertical distance to the target at which the take-off is complete, m."""


def takeoff_height_m(params: CommanderParams) -> float:
    """Default take-off height above the ground: MIS_TAKEOFF_ALT, at least the minimum, m."""
    return max(params.takeoff_alt_m, MIN_TAKEOFF_HEIGHT_M)


def takeoff_target(
    nav: NavInput,
    home: Home,
    params: CommanderParams,
    in_air: bool,
    alt_amsl_m: float | None,
    say: Say,
) -> np.ndarray:
    """The point a take-off climbs to: straight above the vehicle, NED, m.

    On the ground the target is at least MIS_TAKEOFF_ALT (and never less than
    :data:`MIN_TAKEOFF_HEIGHT_M`) above the ground; in the air a target below the vehicle
    keeps the current altitude, as PX4's takeoff does.
    """
    here_amsl = nav.origin_alt_amsl_m - float(nav.position_ned_m[2])
    default_height = takeoff_height_m(params)
    explicit = alt_amsl_m is not None and math.isfinite(alt_amsl_m)
    if alt_amsl_m is None or not explicit:
        alt_amsl_m = home.alt_amsl_m + default_height
    if not in_air and alt_amsl_m < here_amsl + default_height:
        if explicit:
            say(SEVERITY_WARNING, f"Using minimum takeoff altitude: {default_height:.2f} m")
        alt_amsl_m = here_amsl + default_height
    elif in_air and alt_amsl_m < here_amsl:
        alt_amsl_m = here_amsl
        say(SEVERITY_INFO, "Already higher than takeoff altitude")
    target = nav.position_ned_m.copy()
    target[2] = nav.origin_alt_amsl_m - alt_amsl_m
    say(SEVERITY_INFO, f"Takeoff to {alt_amsl_m - home.alt_amsl_m:.1f} m above home")
    return target


def takeoff_reached(nav: NavInput, target_ned_m: np.ndarray) -> bool:
    """The vehicle is within :data:`REACHED_M` of the take-off altitude."""
    return abs(nav.position_ned_m[2] - target_ned_m[2]) < REACHED_M


class TakeoffRamp:
    """Until lift-off, ramp the climb-rate setpoint instead of flying the trajectory.

    As PX4's Takeoff (MPC_TKO_RAMP_T): the vertical velocity setpoint starts where the
    velocity loop asks for zero thrust (g / MPC_Z_VEL_P_ACC downwards) and ramps linearly to
    MPC_TKO_SPEED upwards, so a wrong MPC_THR_HOVER guess cannot throw the vehicle up.
    """

    def __init__(self) -> None:
        self.start_s: float | None = None
        """Simulation time the ramp started; None while not taking off."""

    def apply(self, nav: NavInput, out: NavOutput, params: CommanderParams) -> None:
        """Replace the vertical setpoint of ``out`` by the ramp's climb rate."""
        if self.start_s is None:
            self.start_s = nav.time_s
        ramp_s = max(params.takeoff_ramp_s, 1e-3)
        frac = min(max((nav.time_s - self.start_s) / ramp_s, 0.0), 1.0)
        start = GRAVITY_M_S2 / max(params.z_vel_p_acc_1_s, 0.1)
        end = -params.takeoff_speed_m_s
        out.position_ned_m[2] = np.nan
        out.velocity_ff_m_s = np.array([0.0, 0.0, start + frac * (end - start)])
        out.max_speed_down_m_s = max(out.max_speed_down_m_s, start)
        out.smooth = False
