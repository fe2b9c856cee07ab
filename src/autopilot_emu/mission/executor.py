"""Mission execution: which item is current, where to fly, when an item is reached.

PX4's navigator (mission_base.cpp, mission_block.cpp) as a small state machine, free of I/O.
Each navigation tick the commander hands in the vehicle's position and gets back a
:class:`Leg`: a target point, a yaw and what kind of flight it is. Items:

* NAV_WAYPOINT: fly to x/y/z; reached within the acceptance radius (param2, else NAV_ACC_RAD)
  and NAV_MC_ALT_RAD vertically; then hold param1 s (0: pass through without stopping);
  param4 is the yaw in degrees (NaN: face the direction of travel).
* NAV_TAKEOFF: climb to the item's altitude over the current position.
* NAV_LOITER_TIME (hold param1 s), NAV_LOITER_UNLIM (hold until the mission is changed).
* NAV_LAND: fly to the item's position (0/0: here) at the current altitude, descend and land;
  done once landed.
* NAV_RETURN_TO_LAUNCH: reported complete when it starts (MAVSDK_CONTRACT.md section 14),
  then the commander flies RTL.
* NAV_DELAY (param1 s, holding), DO_JUMP (param1 target, param2 repeats, -1 forever),
  DO_CHANGE_SPEED (param2 m/s, -1 default), DO_SET_ROI_LOCATION / DO_SET_ROI_NONE (yaw towards
  a point); camera, gimbal and actuator items complete at once, the camera items after being
  sent on to the camera as commands (:mod:`autopilot_emu.mission.camera_items`).

A mission started on the ground first takes off vertically to the higher of MIS_TAKEOFF_ALT and
the first position item's altitude (PX4 before v1.14, and what MAVSDK's examples expect).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mission.camera_items import (
    CAMERA_ITEM_COMMANDS,
    CameraItemEmitter,
    ComponentCommand,
)
from autopilot_emu.mission.feasibility import INSTANT_COMMANDS, POSITION_COMMANDS
from autopilot_emu.mission.items import MissionItem, MissionState

NAV_WAYPOINT = mavlink2.MAV_CMD_NAV_WAYPOINT
NAV_TAKEOFF = mavlink2.MAV_CMD_NAV_TAKEOFF
NAV_LAND = mavlink2.MAV_CMD_NAV_LAND
NAV_RTL = mavlink2.MAV_CMD_NAV_RETURN_TO_LAUNCH
NAV_LOITER_TIME = mavlink2.MAV_CMD_NAV_LOITER_TIME
NAV_LOITER_UNLIM = mavlink2.MAV_CMD_NAV_LOITER_UNLIM
NAV_DELAY = mavlink2.MAV_CMD_NAV_DELAY
DO_JUMP = mavlink2.MAV_CMD_DO_JUMP
DO_CHANGE_SPEED = mavlink2.MAV_CMD_DO_CHANGE_SPEED
DO_SET_ROI_LOCATION = mavlink2.MAV_CMD_DO_SET_ROI_LOCATION
DO_SET_ROI_NONE = mavlink2.MAV_CMD_DO_SET_ROI_NONE

_FACE_TRAVEL_MIN_M = 2.0
"""Below this horizontal distance to the target the heading is kept, not turned to it, m."""


class LegKind(Enum):
    """What the commander should do with a leg."""

    FLY = "fly"
    """Fly to ``target_ned_m`` and hold there."""
    LAND = "land"
    """Fly to the target horizontally, then descend and land."""
    RTL = "rtl"
    """Leave the mission and return to launch."""


@dataclass
class Leg:
    """The executor's request for this tick."""

    kind: LegKind
    target_ned_m: np.ndarray
    yaw_rad: float = math.nan
    """Heading setpoint; NaN keeps the current one."""


@dataclass(frozen=True)
class Tolerances:
    """Reach criteria from the parameters."""

    acceptance_radius_m: float
    """NAV_ACC_RAD: horizontal radius when an item gives none."""
    altitude_radius_m: float
    """NAV_MC_ALT_RAD: vertical acceptance, m."""
    takeoff_alt_m: float
    """MIS_TAKEOFF_ALT: minimum take-off height above home, m."""


@dataclass
class StepInput:
    """What one tick of the executor reads (NED, SI)."""

    time_s: float
    position_ned_m: np.ndarray
    yaw_rad: float
    landed: bool
    home_alt_amsl_m: float
    tolerances: Tolerances
    to_ned: Callable[[float, float, float], np.ndarray]
    """(lat deg, lon deg, alt AMSL m) -> local NED, m."""


@dataclass
class MissionExecutor:
    """Progress through one stored mission."""

    items: tuple[MissionItem, ...] = ()
    current: int = 0
    state: MissionState = MissionState.NO_MISSION
    reached: list[int] = field(default_factory=list)
    """Items completed since the commander last read them (MISSION_ITEM_REACHED)."""
    texts: list[str] = field(default_factory=list)
    """Events since the commander last read them (STATUSTEXT, info)."""
    speed_m_s: float | None = None
    """A DO_CHANGE_SPEED since the last read (NaN: back to the default)."""
    component_commands: list[ComponentCommand] = field(default_factory=list)
    """Commands for the camera from camera items, since the commander last read them."""
    _camera: CameraItemEmitter = field(default_factory=CameraItemEmitter)
    _started_item: int | None = None
    _target: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    _yaw: float = math.nan
    _arrived_s: float | None = None
    _delay_until_s: float | None = None
    _jumps: dict[int, int] = field(default_factory=dict)
    _roi: np.ndarray | None = None
    _takeoff_pending: bool = False
    """Activated on the ground: climb before the first item."""

    # -- plan management ---------------------------------------------------------------------
    def load(self, items: tuple[MissionItem, ...], valid: bool) -> None:
        """A new mission (upload or clear): start over at item 0."""
        self.items = items
        self.current = 0
        self.state = MissionState.NOT_STARTED if items and valid else MissionState.NO_MISSION
        self._reset_progress()

    def _reset_progress(self) -> None:
        self._started_item = None
        self._jumps.clear()
        self._roi = None

    def set_current(self, seq: int) -> bool:
        """Continue from item ``seq`` (MISSION_SET_CURRENT)."""
        if not 0 <= seq < len(self.items):
            return False
        self.current = seq
        self._started_item = None
        if self.state == MissionState.COMPLETE:
            self.state = MissionState.PAUSED
        return True

    @property
    def valid(self) -> bool:
        """A mission that can be flown is stored."""
        return self.state != MissionState.NO_MISSION

    def activate(self, landed: bool) -> None:
        """Mission mode entered: resume the current item, or restart a finished mission."""
        if self.state == MissionState.COMPLETE or (landed and self.state == MissionState.PAUSED):
            self.current = 0
            self._reset_progress()
        self._started_item = None
        self._takeoff_pending = landed
        self._target = np.full(3, np.nan)
        self.state = MissionState.ACTIVE
        self.texts.append("Executing Mission")

    def pause(self) -> None:
        """Mission mode left before the end."""
        if self.state == MissionState.ACTIVE:
            self.state = MissionState.PAUSED

    @property
    def landing(self) -> bool:
        """The current item is a landing in progress."""
        return (
            self.state == MissionState.ACTIVE
            and self.current < len(self.items)
            and self.items[self.current].command == NAV_LAND
            and self._started_item == self.current
        )

    # -- the tick ------------------------------------------------------------------------------
    def step(self, inp: StepInput) -> Leg:
        """Advance through completed items and return this tick's leg."""
        pos = inp.position_ned_m
        if self.state != MissionState.ACTIVE:
            return Leg(LegKind.FLY, self._hold_target(pos), self._yaw)
        if self._takeoff_pending:
            return self._takeoff_leg(inp)
        for _ in range(2 * len(self.items) + 1):  # bounded: DO_JUMP loops without flying
            if self.current >= len(self.items):
                return self._finish(inp)
            item = self.items[self.current]
            if item.command == DO_JUMP:
                if self._jump(item):
                    self._complete_item()
                continue
            if self._started_item != self.current:
                self._start(item, inp)
            if item.command == NAV_RTL:
                self._complete_item(last_is_rtl=True)
                return Leg(LegKind.RTL, pos.copy())
            if not self._item_done(item, inp):
                kind = LegKind.LAND if item.command == NAV_LAND else LegKind.FLY
                return Leg(kind, self._target.copy(), self._heading(inp))
            if not item.autocontinue:
                self.texts.append(f"Mission item {self.current} reached, waiting (no autocontinue)")
                self._complete_item()
                self.state = MissionState.PAUSED
                return Leg(LegKind.FLY, self._target.copy(), self._yaw)
            self._complete_item()
        return Leg(LegKind.FLY, self._hold_target(pos), self._yaw)

    def _hold_target(self, pos: np.ndarray) -> np.ndarray:
        return self._target.copy() if np.isfinite(self._target).all() else pos.copy()

    def _takeoff_leg(self, inp: StepInput) -> Leg:
        """Climb over the start point to the mission's take-off height, then go on."""
        if not np.isfinite(self._target).all():
            first = next(
                (it for it in self.items[self.current :] if it.command in POSITION_COMMANDS),
                None,
            )
            height = inp.tolerances.takeoff_alt_m
            if first is not None and first.command != NAV_LAND:
                alt = first.alt_amsl_m(inp.home_alt_amsl_m)
                if math.isfinite(alt):
                    height = max(height, alt - inp.home_alt_amsl_m)
            self._target = inp.position_ned_m.copy()
            self._target[2] -= height
            self._yaw = inp.yaw_rad
        if abs(inp.position_ned_m[2] - self._target[2]) < inp.tolerances.altitude_radius_m:
            self._takeoff_pending = False
        return Leg(LegKind.FLY, self._target.copy(), self._yaw)

    def _start(self, item: MissionItem, inp: StepInput) -> None:
        """Set up the current item's target (or do it, for items without flight)."""
        self._started_item = self.current
        self._arrived_s = None
        self._delay_until_s = None
        pos = inp.position_ned_m
        command = item.command
        if command in POSITION_COMMANDS:
            target = pos.copy() if not np.isfinite(self._target).all() else self._target.copy()
            if item.has_position:
                alt = item.alt_amsl_m(inp.home_alt_amsl_m)
                point = inp.to_ned(item.lat_deg, item.lon_deg, alt if math.isfinite(alt) else 0.0)
                target[:2] = point[:2]
                if math.isfinite(alt):
                    target[2] = point[2]
            elif math.isfinite(item.alt_amsl_m(inp.home_alt_amsl_m)):
                alt = item.alt_amsl_m(inp.home_alt_amsl_m)
                target[2] = inp.to_ned(0.0, 0.0, alt)[2]
            if command == NAV_TAKEOFF:
                target[:2] = pos[:2]
            if command == NAV_LAND:  # approach at the current altitude; the descent follows
                target[2] = self._target[2] if np.isfinite(self._target[2]) else pos[2]
            self._target = target
            yaw_deg = item.params[3]
            self._yaw = math.radians(yaw_deg) if math.isfinite(yaw_deg) else math.nan
        elif command == NAV_DELAY:
            self._delay_until_s = inp.time_s + item.params[0]
        elif command == DO_CHANGE_SPEED:
            speed = item.params[1]
            self.speed_m_s = speed if math.isfinite(speed) and speed > 0 else math.nan
        elif command == DO_SET_ROI_LOCATION:
            alt = item.alt_amsl_m(inp.home_alt_amsl_m)
            self._roi = inp.to_ned(item.lat_deg, item.lon_deg, alt if math.isfinite(alt) else 0.0)
        elif command == DO_SET_ROI_NONE:
            self._roi = None
        elif command in CAMERA_ITEM_COMMANDS:
            emitted = self._camera.command_for(item)
            if emitted is not None:
                self.component_commands.append(emitted)

    def _item_done(self, item: MissionItem, inp: StepInput) -> bool:
        command = item.command
        if command in INSTANT_COMMANDS or command in (
            DO_CHANGE_SPEED,
            DO_SET_ROI_LOCATION,
            DO_SET_ROI_NONE,
        ):
            return True
        if command == NAV_DELAY:
            return self._delay_until_s is not None and inp.time_s >= self._delay_until_s
        if command == NAV_LAND:
            return inp.landed
        if command == NAV_LOITER_UNLIM:
            return False
        if not self._at_target(item, inp):
            return False
        hold_s = item.params[0] if command in (NAV_WAYPOINT, NAV_LOITER_TIME) else 0.0
        if not (math.isfinite(hold_s) and hold_s > 0):
            return True
        if self._arrived_s is None:
            self._arrived_s = inp.time_s
        return inp.time_s - self._arrived_s >= hold_s

    def _at_target(self, item: MissionItem, inp: StepInput) -> bool:
        err = inp.position_ned_m - self._target
        radius = item.params[1] if item.command == NAV_WAYPOINT else math.nan
        if not (math.isfinite(radius) and radius > 0):
            radius = inp.tolerances.acceptance_radius_m
        if item.command == NAV_TAKEOFF:
            radius = math.inf
        return bool(
            math.hypot(err[0], err[1]) <= radius and abs(err[2]) <= inp.tolerances.altitude_radius_m
        )

    def _jump(self, item: MissionItem) -> bool:
        """DO_JUMP: move ``current`` to the target while repeats remain; True when exhausted."""
        repeats = int(item.params[1])
        done = self._jumps.get(self.current, 0)
        if repeats != -1 and done >= repeats:
            return True
        self._jumps[self.current] = done + 1
        self.current = int(item.params[0])
        self._started_item = None
        return False

    def _complete_item(self, last_is_rtl: bool = False) -> None:
        self.reached.append(self.current)
        if last_is_rtl:
            self.state = MissionState.COMPLETE
            self.texts.append("Mission finished, returning to launch")
            return
        self.current += 1
        self._started_item = None

    def _finish(self, inp: StepInput) -> Leg:
        self.current = max(0, len(self.items) - 1)
        self.state = MissionState.COMPLETE
        self._jumps.clear()
        self.texts.append(
            "Mission finished, landed" if inp.landed else "Mission finished, loitering"
        )
        return Leg(LegKind.FLY, self._hold_target(inp.position_ned_m), self._yaw)

    def _heading(self, inp: StepInput) -> float:
        """ROI first, then the item's yaw, then the direction of travel."""
        pos = inp.position_ned_m
        if self._roi is not None:
            d = self._roi - pos
            if math.hypot(d[0], d[1]) > 0.5:
                return math.atan2(d[1], d[0])
        if math.isfinite(self._yaw):
            return self._yaw
        d = self._target - pos
        if np.isfinite(d[:2]).all() and math.hypot(d[0], d[1]) > _FACE_TRAVEL_MIN_M:
            return math.atan2(d[1], d[0])
        return math.nan
