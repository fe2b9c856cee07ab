"""Land detector of one vehicle: when a take-off has left the ground, and when a flight has landed.

After PX4's MulticopterLandDetector, reduced to what the navigation rate sees: a take-off is in
the air once it is 0.5 m above home or climbs faster than 0.5 m/s; a flight has landed after
:data:`LANDED_AFTER_S` of low thrust (or a slow final descent) without vertical or horizontal
motion. The commander owns the landed state and the announcements; this module decides.
"""

from __future__ import annotations

import math

from autopilot_emu.modes import LandedState
from autopilot_emu.modes.nav_types import SEVERITY_INFO, Home, NavInput, Say

LANDED_AFTER_S = 1.0
"""How long the landed conditions must hold, s."""
LIFTOFF_HEIGHT_M = 0.5
"""Height above home at which a take-off is in the air, m."""
LIFTOFF_CLIMB_M_S = 0.5
"""Climb rate at which a take-off is in the air, m/s."""
MIN_THRUST_LANDED = 0.1
"""Collective thrust below which a still vehicle without a learned hover thrust is landed (just
above the position controller's 0.05 floor)."""

_ON_GROUND, _TAKING_OFF, _IN_AIR = LandedState.ON_GROUND, LandedState.TAKEOFF, LandedState.IN_AIR


class LandDetector:
    """Lift-off and touch-down detection from the estimate and the thrust command.

    Args:
        say: announces a detected landing.
    """

    def __init__(self, say: Say) -> None:
        self._say = say
        self.candidate_s: float | None = None
        """Since when the landed conditions hold; None while they do not."""
        self.ground_since_s: float | None = None
        """Simulation time of the last landing detected; None before the first."""

    def update(
        self,
        nav: NavInput,
        state: LandedState,
        armed: bool,
        descending: bool,
        home: Home | None,
    ) -> LandedState:
        """The landed state after this tick (``descending``: in a final descent)."""
        vx, vy, vz_signed = nav.velocity_ned_m_s.tolist()
        vz = abs(vz_signed)
        vxy = math.hypot(vx, vy)
        if state == _TAKING_OFF and not armed:
            return _ON_GROUND
        if state in (_ON_GROUND, _TAKING_OFF):
            if (
                armed
                and state == _TAKING_OFF
                and (_height_m(nav, home) > LIFTOFF_HEIGHT_M or vz_signed < -LIFTOFF_CLIMB_M_S)
            ):
                return _IN_AIR
            return state
        if math.isfinite(nav.hover_thrust):
            low_thrust = nav.thrust < 0.6 * nav.hover_thrust
        else:
            # No learned hover thrust yet (PX4's MPC_THR_HOVER default is a guess that can be
            # twice the real value): only thrust near the controller's minimum counts as low,
            # so a vehicle hovering on a light thrust is not "landed" in the air.
            low_thrust = nav.thrust < MIN_THRUST_LANDED
        low_thrust = low_thrust or not armed
        # Without a position fix the horizontal velocity estimate drifts: judge by vertical only.
        still = vz < 0.3 and (vxy < 0.5 or not nav.position_ok)
        if still and (low_thrust or (descending and vz < 0.1)):
            if self.candidate_s is None:
                self.candidate_s = nav.time_s
            if nav.time_s - self.candidate_s >= LANDED_AFTER_S:
                self.ground_since_s = nav.time_s
                self.candidate_s = None
                self._say(SEVERITY_INFO, "Landing detected")
                return _ON_GROUND
        else:
            self.candidate_s = None
        return state


def _height_m(nav: NavInput, home: Home | None) -> float:
    """Height above home, m (0 without a home)."""
    if home is None:
        return 0.0
    return float(home.position_ned_m[2] - nav.position_ned_m[2])
