"""Return-To-Launch: climb to RTL_RETURN_ALT, fly to home or the closest rally point, land.

As PX4's navigator RTL (without its cone and loiter-before-land options): the return altitude
is home + RTL_RETURN_ALT, or the current altitude when that is higher; the destination is home
or the closest rally point, whichever is nearer; the last phase is Land's descent
(:mod:`autopilot_emu.modes.land`).
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import Enum

import numpy as np

from autopilot_emu import geodesy
from autopilot_emu.mission.items import MissionItem
from autopilot_emu.modes.nav_types import SEVERITY_INFO, Home, NavInput, Say

CLIMBED_M = 0.5
"""Distance below the return altitude at which the climb is complete, m."""
ARRIVAL_SPEED_M_S = 0.5
"""Horizontal speed below which the vehicle has arrived over the destination, m/s."""


class RtlPhase(Enum):
    """Phases of Return-To-Launch."""

    CLIMB = "climb"
    RETURN = "return"
    LAND = "land"


_CLIMB, _RETURN, _LAND = RtlPhase.CLIMB, RtlPhase.RETURN, RtlPhase.LAND


def destination(
    here_ned_m: np.ndarray,
    home: Home,
    rally: Iterable[MissionItem],
    origin: np.ndarray | None,
) -> tuple[np.ndarray, int | None]:
    """Home or the closest rally point, whichever is nearer (horizontal NED, m), and its index.

    ``origin``: the NED origin (lat, lon, alt AMSL); None before the first fix (home then).
    """
    here = here_ned_m[:2]
    best, best_index = home.position_ned_m[:2].copy(), None
    best_dist = float(np.hypot(*(best - here)))
    if origin is None:
        return best, None
    for index, item in enumerate(rally):
        point = geodesy.geodetic_to_ned(np.array([item.lat_deg, item.lon_deg, 0.0]), origin)
        dist = float(np.hypot(*(point[:2] - here)))
        if dist < best_dist:
            best, best_index, best_dist = point[:2], index, dist
    return best, best_index


class Rtl:
    """The phase of one vehicle's return and where it goes.

    Args:
        say: announces the phase changes.
    """

    def __init__(self, say: Say) -> None:
        self._say = say
        self.phase = RtlPhase.CLIMB
        self.alt_ned_z = 0.0
        """Return altitude as NED down coordinate, m."""
        self.dest_ned = np.zeros(2)
        """Horizontal destination (home or a rally point), NED, m."""

    @property
    def landing(self) -> bool:
        """In the final descent."""
        return self.phase is _LAND

    def start(
        self,
        nav: NavInput,
        home: Home,
        return_alt_m: float,
        rally: Iterable[MissionItem],
        origin: np.ndarray | None,
    ) -> tuple[np.ndarray, str]:
        """Begin a return (``return_alt_m``: RTL_RETURN_ALT): the climb target and its text."""
        self.alt_ned_z = min(
            nav.position_ned_m[2], nav.origin_alt_amsl_m - (home.alt_amsl_m + return_alt_m)
        )
        self.phase = RtlPhase.CLIMB
        target = nav.position_ned_m.copy()
        target[2] = self.alt_ned_z
        self.dest_ned, index = destination(nav.position_ned_m, home, rally, origin)
        above_home = nav.origin_alt_amsl_m - self.alt_ned_z - home.alt_amsl_m
        where = f"rally point {index + 1}" if index is not None else "home"
        return target, f"RTL: return to {where} at {above_home:.0f} m"

    def step(self, nav: NavInput, target: np.ndarray, acceptance_radius_m: float) -> np.ndarray:
        """Advance the climb or the return; the target from now on (``target`` if unchanged).

        ``acceptance_radius_m``: NAV_ACC_RAD (arrival within half of it). Not called while
        landing: the descent is Land's.
        """
        if self.phase is _CLIMB:
            if nav.position_ned_m[2] - self.alt_ned_z < CLIMBED_M:
                self.phase = _RETURN
                dest = self.dest_ned
                target = np.array([dest[0], dest[1], self.alt_ned_z])
                self._say(SEVERITY_INFO, "RTL: returning")
        elif self.phase is _RETURN:
            dest = self.dest_ned
            dist = float(np.hypot(*(nav.position_ned_m[:2] - dest)))
            vel = nav.velocity_ned_m_s
            if dist < acceptance_radius_m * 0.5 and np.hypot(vel[0], vel[1]) < ARRIVAL_SPEED_M_S:
                self.phase = _LAND
                target = np.array([dest[0], dest[1], np.nan])
                self._say(SEVERITY_INFO, "RTL: landing")
        return target
