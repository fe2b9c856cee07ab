"""What the navigator reads and writes at each 50 Hz tick: one vehicle, NED frame, SI units.

The commander and every flight mode speak these types: :class:`NavInput` is the estimate and the
last thrust command, :class:`NavOutput` the setpoint handed to the batched controllers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

SEVERITY_CRITICAL, SEVERITY_WARNING, SEVERITY_NOTICE, SEVERITY_INFO = 2, 4, 5, 6
"""MAV_SEVERITY of the status texts the navigator announces."""

Say = Callable[[int, str], None]
"""Announces a status text (MAV_SEVERITY, text)."""


@dataclass
class NavInput:
    """What the navigator reads at each tick (one vehicle, NED, SI)."""

    time_s: float
    position_ned_m: np.ndarray
    velocity_ned_m_s: np.ndarray
    yaw_rad: float
    position_ok: bool
    thrust: float
    """Last collective thrust command, 0..1."""
    origin_alt_amsl_m: float
    origin_lat_lon_deg: tuple[float, float] = (math.nan, math.nan)
    """Latitude and longitude of the NED origin, deg (NaN before the first fix)."""
    battery_remaining: float = math.nan
    """Estimated state of charge, 0..1."""
    hover_thrust: float = math.nan
    """The learned hover thrust (the hover-thrust estimator's, once valid), 0..1; NaN until then
    (the commander then uses MPC_THR_HOVER, as the position controller does)."""


TrajectoryState = tuple[np.ndarray, np.ndarray, np.ndarray]
"""Position, velocity and acceleration of a smoothed setpoint, NED."""

_NAN3 = np.full(3, np.nan)
_ZERO3 = np.zeros(3)


@dataclass
class NavOutput:
    """Setpoint for the position controller (NaN components = velocity control)."""

    position_ned_m: np.ndarray = field(default_factory=_NAN3.copy)
    velocity_ff_m_s: np.ndarray = field(default_factory=_ZERO3.copy)
    """Velocity feed-forward, or the velocity setpoint on an axis without position (NaN on an
    axis without position either: acceleration control there)."""
    acceleration_ff_m_s2: np.ndarray = field(default_factory=_ZERO3.copy)
    yaw_rad: float = 0.0
    max_speed_xy_m_s: float = 5.0
    max_speed_up_m_s: float = 3.0
    max_speed_down_m_s: float = 1.5
    active: bool = False
    """False while on the ground: motors idle, controllers reset."""
    smooth: bool = False
    """Auto modes: the target goes through the jerk-limited trajectory (offboard: as given)."""
    attitude_wxyz: np.ndarray | None = None
    """Offboard attitude setpoint: replaces the position controller's attitude."""
    body_rates_rad_s: np.ndarray | None = None
    """Offboard body-rate setpoint (NaN per axis: from the attitude loop)."""
    thrust: float = math.nan
    """Offboard collective thrust 0..1 of an attitude or rate setpoint."""


@dataclass
class Home:
    """Home in the vehicle's NED frame and as AMSL altitude."""

    position_ned_m: np.ndarray
    alt_amsl_m: float


def origin_lla(nav: NavInput | None) -> np.ndarray | None:
    """The NED origin as (lat deg, lon deg, alt AMSL m); None before the first fix."""
    if nav is None or not math.isfinite(nav.origin_lat_lon_deg[0]):
        return None
    return np.array([*nav.origin_lat_lon_deg, nav.origin_alt_amsl_m])
