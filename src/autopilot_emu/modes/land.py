"""Land mode: descend at the current position, fast high up and slowly near the ground.

As PX4's navigator Land: the horizontal position is held and the vertical axis is velocity
controlled, at MPC_Z_V_AUTO_DN above :data:`SLOW_BELOW_M` and MPC_LAND_SPEED below. The same
descent ends RTL and a mission's landing item; the land detector ends it.
"""

from __future__ import annotations

import numpy as np

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.modes.nav_types import NavOutput

SLOW_BELOW_M = 10.0
"""Height above home below which the descent slows to MPC_LAND_SPEED, m."""


def land_target(position_ned_m: np.ndarray) -> np.ndarray:
    """The setpoint of a landing here: this horizontal position, no altitude (NaN), NED."""
    target = position_ned_m.copy()
    target[2] = np.nan
    return target


def descend(out: NavOutput, height_m: float, params: CommanderParams) -> None:
    """Make ``out`` a descent at ``height_m`` above home."""
    out.position_ned_m[2] = np.nan
    speed = params.auto_descent_speed_m_s if height_m > SLOW_BELOW_M else params.land_speed_m_s
    out.velocity_ff_m_s = np.array([0.0, 0.0, speed])
