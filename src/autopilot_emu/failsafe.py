"""Failsafe conditions and the actions PX4 takes for them (commander's failsafe framework).

Four conditions are watched: ground-station data link (NAV_DLL_ACT after COM_DL_LOSS_T without
a GCS HEARTBEAT), battery (BAT_LOW_THR / BAT_CRIT_THR / BAT_EMERGEN_THR with COM_LOW_BAT_ACT),
loss of the global position (GPS), and a geofence breach (GF_ACTION). :class:`FailsafeMonitor`
is pure: it turns the tick's inputs into the texts to announce and the most severe action that
became due; the commander carries the action out. An action is taken when its condition
starts (or the battery level worsens); the pilot may take over afterwards, as in PX4.
:func:`outside_fence` is the geofence test itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from autopilot_emu import geodesy
from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.mission.geofence import Fence
from autopilot_emu.modes.nav_types import NavInput, origin_lla

SEVERITY_CRITICAL, SEVERITY_WARNING, SEVERITY_INFO = 2, 4, 6


class Action(IntEnum):
    """Failsafe actions, ordered by severity (PX4 takes the most severe active one)."""

    NONE = 0
    WARN = 1
    HOLD = 2
    RTL = 3
    LAND = 4
    DISARM = 5
    TERMINATE = 6


DLL_ACTIONS = {
    0: Action.NONE,
    1: Action.HOLD,
    2: Action.RTL,
    3: Action.LAND,
    5: Action.TERMINATE,
    6: Action.DISARM,
}
"""NAV_DLL_ACT values."""
GF_ACTIONS = {
    0: Action.NONE,
    1: Action.WARN,
    2: Action.HOLD,
    3: Action.RTL,
    4: Action.TERMINATE,
    5: Action.LAND,
}
"""GF_ACTION values."""
ACTION_NAMES = {
    Action.HOLD: "Hold",
    Action.RTL: "Return",
    Action.LAND: "Land",
    Action.DISARM: "Disarm",
    Action.TERMINATE: "Terminate",
}


class BatteryLevel(IntEnum):
    """Battery warning levels."""

    OK = 0
    LOW = 1
    CRITICAL = 2
    EMERGENCY = 3


def battery_action(level: BatteryLevel, com_low_bat_act: int) -> Action:
    """COM_LOW_BAT_ACT: 0 warn, 1 return, 2 land, 3 return at critical and land at emergency."""
    if level == BatteryLevel.OK:
        return Action.NONE
    if level == BatteryLevel.LOW or com_low_bat_act == 0:
        return Action.WARN
    if com_low_bat_act == 1:
        return Action.RTL
    if com_low_bat_act == 2:
        return Action.LAND
    return Action.RTL if level == BatteryLevel.CRITICAL else Action.LAND


BATTERY_TEXTS = {
    BatteryLevel.LOW: (SEVERITY_WARNING, "Low battery level, return advised"),
    BatteryLevel.CRITICAL: (SEVERITY_CRITICAL, "Critical battery level, land now"),
    BatteryLevel.EMERGENCY: (SEVERITY_CRITICAL, "Emergency battery level, land immediately"),
}


@dataclass
class FailsafeInput:
    """One tick's view of the conditions."""

    time_s: float
    armed: bool
    in_air: bool
    landing: bool
    """Already landing (data-link loss is then ignored, as PX4 does)."""
    battery_remaining: float
    """State of charge 0..1; NaN unknown."""
    position_ok: bool
    fence_breached: bool
    gcs_heard_s: float | None
    """Simulation time of the last GCS HEARTBEAT; None if none was ever heard."""


@dataclass
class FailsafeMonitor:
    """Edge detection of the failsafe conditions of one vehicle."""

    params: CommanderParams
    """The vehicle's parameters; its commander replaces them when the store changes."""
    texts: list[tuple[int, str]] = field(default_factory=list)
    datalink_lost: bool = False
    battery_level: BatteryLevel = BatteryLevel.OK
    position_lost: bool = False
    fence_breached: bool = False

    def update(self, inp: FailsafeInput) -> Action:
        """Announce changes; return the most severe action that became due this tick."""
        action = max(self._datalink(inp), self._battery(inp), self._position(inp), self._fence(inp))
        if action > Action.WARN:
            self.texts.append(
                (SEVERITY_CRITICAL, f"Failsafe activated: switching to {ACTION_NAMES[action]}")
            )
        return action

    def _datalink(self, inp: FailsafeInput) -> Action:
        if inp.gcs_heard_s is None:
            return Action.NONE
        lost = inp.time_s - inp.gcs_heard_s > self.params.datalink_loss_timeout_s
        if lost == self.datalink_lost:
            return Action.NONE
        self.datalink_lost = lost
        if not lost:
            self.texts.append((SEVERITY_INFO, "GCS connection regained"))
            return Action.NONE
        self.texts.append((SEVERITY_CRITICAL, "Connection to ground station lost"))
        if not (inp.armed and inp.in_air) or inp.landing:
            return Action.NONE
        return DLL_ACTIONS.get(self.params.datalink_loss_action, Action.NONE)

    def _battery(self, inp: FailsafeInput) -> Action:
        remaining = inp.battery_remaining
        if not math.isfinite(remaining):
            return Action.NONE
        p = self.params
        # The most severe level whose threshold (BAT_EMERGEN_THR, BAT_CRIT_THR, BAT_LOW_THR) is met.
        if remaining <= p.battery_emergency:
            level = BatteryLevel.EMERGENCY
        elif remaining <= p.battery_critical:
            level = BatteryLevel.CRITICAL
        elif remaining <= p.battery_low:
            level = BatteryLevel.LOW
        else:
            level = BatteryLevel.OK
        if level <= self.battery_level:
            if level == BatteryLevel.OK:
                self.battery_level = level  # recharged / new battery
            return Action.NONE
        self.battery_level = level
        self.texts.append(BATTERY_TEXTS[level])
        if not (inp.armed and inp.in_air):
            return Action.NONE
        return battery_action(level, p.low_battery_action)

    def _position(self, inp: FailsafeInput) -> Action:
        lost = inp.armed and inp.in_air and not inp.position_ok
        if lost == self.position_lost:
            return Action.NONE
        self.position_lost = lost
        if not lost:
            if inp.position_ok:  # not merely landed or disarmed without it
                self.texts.append((SEVERITY_INFO, "Global position regained"))
            return Action.NONE
        self.texts.append((SEVERITY_CRITICAL, "No global position: GPS lost"))
        return Action.LAND

    def _fence(self, inp: FailsafeInput) -> Action:
        breached = inp.fence_breached
        if breached == self.fence_breached:
            return Action.NONE
        self.fence_breached = breached
        if not breached:
            self.texts.append((SEVERITY_INFO, "Geofence OK"))
            return Action.NONE
        self.texts.append((SEVERITY_CRITICAL, "Geofence violation"))
        if not (inp.armed and inp.in_air):
            return Action.NONE
        return GF_ACTIONS.get(self.params.fence_action, Action.NONE)


def outside_fence(
    nav: NavInput, home_ned_m: np.ndarray, fence: Fence, params: CommanderParams
) -> bool:
    """Outside the geofence areas, or beyond GF_MAX_HOR_DIST / GF_MAX_VER_DIST of home.

    A distance limit of 0 is off.
    """
    offset = nav.position_ned_m - home_ned_m
    max_hor = params.fence_max_hor_dist_m
    max_ver = params.fence_max_ver_dist_m
    if 0 < max_hor < float(np.hypot(offset[0], offset[1])) or 0 < max_ver < -offset[2]:
        return True
    origin = origin_lla(nav)
    if fence.empty or origin is None:
        return False
    lat, lon, _ = geodesy.ned_to_geodetic(nav.position_ned_m, origin)
    return not fence.contains(float(lat), float(lon))
