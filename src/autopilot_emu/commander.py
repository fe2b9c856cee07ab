"""Commander of one vehicle: arming, mode switching, failsafes, and the 50 Hz navigation tick.

PX4 splits this between commander (arming, mode switching, failsafes), navigator (AUTO modes)
and land_detector. Here each flight mode computes its own setpoint in :mod:`autopilot_emu.modes`
(takeoff, land, rtl, hold, mission, offboard), the land detector decides in
:mod:`autopilot_emu.land_detector`, and the failsafe conditions are watched by
:mod:`autopilot_emu.failsafe`; the commander owns the state they share (armed, the mode, the
landed state, home, the current target) and dispatches to the active mode at each tick. It is
pure logic: it reads the estimate and parameters, and writes position setpoints for the batched
controllers. The parameters are read as :class:`~autopilot_emu.commander_params.CommanderParams`,
rebuilt from the vehicle's store whenever the store's version changes.

Results are MAV_RESULT values: 0 accepted, 1 temporarily rejected, 2 denied.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.failsafe import (
    ACTION_NAMES,
    Action,
    FailsafeInput,
    FailsafeMonitor,
    outside_fence,
)
from autopilot_emu.land_detector import LandDetector
from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.mission.executor import LegKind, MissionExecutor
from autopilot_emu.mission.geofence import Fence, build_fence
from autopilot_emu.mission.items import MissionItem, MissionState, MissionStore, MissionType
from autopilot_emu.modes import AutoSubMode, LandedState, MainMode
from autopilot_emu.modes.hold import braking_point, reposition_target
from autopilot_emu.modes.land import descend, land_target
from autopilot_emu.modes.mission import (
    mission_feasible,
    mission_leg,
    over_landing_point,
    take_events,
)
from autopilot_emu.modes.nav_types import (
    SEVERITY_CRITICAL,
    SEVERITY_INFO,
    SEVERITY_WARNING,
    Home,
    NavInput,
    NavOutput,
    TrajectoryState,
    origin_lla,
)
from autopilot_emu.modes.offboard import OffboardControl, OffboardSetpoint, loss_action
from autopilot_emu.modes.rtl import Rtl, RtlPhase
from autopilot_emu.modes.takeoff import TakeoffRamp, takeoff_reached, takeoff_target
from autopilot_emu.params import ParamStore

ACCEPTED, TEMPORARILY_REJECTED, DENIED = 0, 1, 2
FORCE_MAGIC = 21196
"""MAV_CMD_COMPONENT_ARM_DISARM param2 that forces (kills) regardless of state."""
MAV_MISSION_ACCEPTED = 0
_MANUAL_MODES = (
    MainMode.POSCTL,
    MainMode.ALTCTL,
    MainMode.MANUAL,
    MainMode.STABILIZED,
    MainMode.ACRO,
    MainMode.RATTITUDE,
)
"""Modes that need RC or MANUAL_CONTROL, which the emulator never has."""

# Enum members as module constants: an enum attribute look-up costs ~0.3 us in Python 3.11 and
# the 50 Hz tick compares states a dozen times.
_ON_GROUND, _TAKING_OFF = LandedState.ON_GROUND, LandedState.TAKEOFF
_IN_AIR, _LANDING = LandedState.IN_AIR, LandedState.LANDING
_SUB_TAKEOFF, _SUB_MISSION = AutoSubMode.TAKEOFF, AutoSubMode.MISSION
_SUB_LAND, _SUB_RTL = AutoSubMode.LAND, AutoSubMode.RTL
_OFFBOARD = MainMode.OFFBOARD
_RTL_LAND = RtlPhase.LAND


class Commander:
    """Arming, PX4 modes and their switching, failsafes and the navigation tick of one vehicle."""

    def __init__(self, params: ParamStore) -> None:
        self.params = params
        """The vehicle's parameter store (read through :meth:`_settings`)."""
        self._settings_cache = CommanderParams.from_params(params)
        self._settings_version = params.version
        self.armed = False
        self.main_mode = MainMode.AUTO
        self.sub_mode = AutoSubMode.LOITER
        self.landed_state = LandedState.ON_GROUND
        self.home: Home | None = None
        self.status_texts: list[tuple[int, str]] = []
        self._target = np.full(3, np.nan)
        """The active mode's position setpoint, NED (PX4's current setpoint of the triplet)."""
        self._yaw_sp = 0.0
        self._speed_override_m_s = math.nan
        self._arm_time_s = 0.0
        self._last: NavInput | None = None
        self._dt_s = 0.004
        self.trajectory_state: Callable[[], TrajectoryState | None] | None = None
        """The fleet's view of this vehicle's smoothed setpoint (None while it is not smoothing):
        Hold stops where that setpoint can stop."""
        self.killed = False
        self.terminated = False
        """Flight termination ran (MAV_CMD_DO_FLIGHTTERMINATION): HEARTBEAT reports
        MAV_STATE_FLIGHT_TERMINATION until the vehicle is armed again."""
        self.missions = MissionStore()
        self.mission = MissionExecutor()
        self.mission_reached: list[int] = []
        self.component_commands: list[ComponentCommand] = []
        """Commands for the vehicle's other components (mission camera items), not yet sent."""
        self.fence = Fence()
        self.fence_breached = False
        self.failsafe = FailsafeMonitor(self._settings_cache)
        self._gcs_heard_s: float | None = None
        self.offboard = OffboardControl()
        self._rtl = Rtl(self._say)
        self._takeoff_ramp = TakeoffRamp()
        self._land_detector = LandDetector(self._say)
        self._offboard_fallback: tuple[MainMode, AutoSubMode] | None = None
        """Mode the offboard-loss failsafe switched to; Offboard resumes from it when the
        setpoint stream comes back (PX4's mode fallback clears with its condition)."""

    # -- helpers ------------------------------------------------------------------------------
    def _settings(self) -> CommanderParams:
        """The store's current values, rebuilt (also for the failsafe monitor) when it changed."""
        store = self.params
        if store.version != self._settings_version:
            self._settings_cache = self.failsafe.params = CommanderParams.from_params(store)
            self._settings_version = store.version
        return self._settings_cache

    def _say(self, severity: int, text: str) -> None:
        self.status_texts.append((severity, text))

    @property
    def in_air(self) -> bool:
        """True from takeoff detection until landing is detected."""
        return self.landed_state != _ON_GROUND

    def _hover_thrust(self, p: CommanderParams) -> float:
        """The hover thrust in use: the estimate the fleet passes in, else MPC_THR_HOVER."""
        if self._last is not None and math.isfinite(self._last.hover_thrust):
            return self._last.hover_thrust
        return p.hover_thrust

    def _cruise_m_s(self, p: CommanderParams) -> float:
        """Horizontal speed of the auto modes: the speed override, else MPC_XY_CRUISE."""
        cruise = self._speed_override_m_s
        if not math.isfinite(cruise):
            cruise = p.cruise_speed_m_s
        return min(cruise, p.max_speed_xy_m_s)

    def _now(self) -> float:
        return self._last.time_s if self._last else 0.0

    def _position(self) -> np.ndarray:
        return self._last.position_ned_m.copy() if self._last else np.zeros(3)

    def _set_mode(self, main: MainMode, sub: AutoSubMode = AutoSubMode.NONE) -> None:
        if self.sub_mode == AutoSubMode.MISSION and sub != AutoSubMode.MISSION:
            self.mission.pause()
        self.main_mode, self.sub_mode = main, sub

    def _hold_here(self) -> None:
        """Hold (AUTO_LOITER) where the vehicle can stop (:func:`modes.hold.braking_point`)."""
        nav = self._last
        if nav is not None and self.in_air:
            p = self._settings()
            self._target = braking_point(
                nav, p, self.trajectory_state, self._cruise_m_s(p), self._dt_s
            )
        else:
            self._target = self._position()
        self._yaw_sp = nav.yaw_rad if nav else 0.0
        self._set_mode(MainMode.AUTO, AutoSubMode.LOITER)

    # -- commands ------------------------------------------------------------------------------
    def set_home_here(self) -> None:
        """Home := current estimate (PX4 sets home on arming and at the first good fix)."""
        if self._last is None or not self._last.position_ok:
            return
        pos = self._last.position_ned_m.copy()
        self.home = Home(pos, self._last.origin_alt_amsl_m - pos[2])
        mission = self.missions.items(MissionType.MISSION)
        if mission and not self.mission.valid:  # e.g. relative altitudes waited for a home
            self.mission.load(mission, self._mission_feasible())

    def arm(self, force: bool) -> int:
        """Arm if armable (good position, on the ground), or unconditionally when forced."""
        if self.armed:
            return ACCEPTED
        ready = self._last is not None and self._last.position_ok
        if not ready and not force:
            self._say(SEVERITY_CRITICAL, "Arming denied: no valid position estimate")
            return DENIED
        # Arming never takes off: only modes that stay on the ground are kept (MAVSDK's arm()
        # itself switches Mission and RTL to Hold first).
        keep_offboard = self.main_mode == MainMode.OFFBOARD and self._offboard_fresh(
            self._settings()
        )
        if not keep_offboard and (
            self.main_mode != MainMode.AUTO
            or self.sub_mode not in (AutoSubMode.LOITER, AutoSubMode.LAND)
        ):
            self._hold_here()
        self.armed = True
        self.killed = False
        self.terminated = False
        self._arm_time_s = self._now()
        if not self.in_air:
            self.set_home_here()
            self._target = self._position()
        self._say(SEVERITY_INFO, "Armed by external command")
        return ACCEPTED

    def disarm(self, force: bool) -> int:
        """Disarm on the ground; in the air only when forced (kill)."""
        if not self.armed:
            return ACCEPTED
        if self.in_air and not force:
            self._say(SEVERITY_CRITICAL, "Disarming denied: not landed")
            return DENIED
        self._disarm("Disarmed by external command" if not force else "Kill switch engaged")
        if force:
            self.killed = True
        return ACCEPTED

    def _disarm(self, text: str) -> None:
        # The mode stays what it was (PX4 shows LAND / RTL after landing); that is why MAVSDK's
        # arm() switches to Hold first when it finds the vehicle in RTL or Mission.
        self.armed = False
        if self.landed_state == LandedState.TAKEOFF:
            self.landed_state = LandedState.ON_GROUND  # disarmed before leaving the ground
        self._say(SEVERITY_INFO, text)

    def takeoff(self, alt_amsl_m: float | None) -> int:
        """Climb to alt_amsl_m (NAV_TAKEOFF param7, AMSL), or to home + MIS_TAKEOFF_ALT.

        Where to: :func:`~autopilot_emu.modes.takeoff.takeoff_target`.
        """
        if not self.armed:
            self._say(SEVERITY_CRITICAL, "Takeoff denied: disarmed")
            return DENIED
        nav = self._last
        if nav is None or not nav.position_ok or self.home is None:
            return TEMPORARILY_REJECTED
        in_air = self.in_air
        self._target = takeoff_target(
            nav, self.home, self._settings(), in_air, alt_amsl_m, self._say
        )
        self._yaw_sp = nav.yaw_rad
        self._set_mode(MainMode.AUTO, AutoSubMode.TAKEOFF)
        if not in_air:
            self.landed_state = LandedState.TAKEOFF
        return ACCEPTED

    def land(self) -> int:
        """Descend and land at the current position."""
        if not self.armed:
            return DENIED
        self._target = land_target(self._position())
        self._yaw_sp = self._last.yaw_rad if self._last else 0.0
        self._set_mode(MainMode.AUTO, AutoSubMode.LAND)
        self._say(SEVERITY_INFO, "Landing at current position")
        return ACCEPTED

    def return_to_launch(self) -> int:
        """Climb to RTL_RETURN_ALT, fly home (or to the closest rally point), land (PX4 RTL)."""
        nav = self._last
        if self.home is None or nav is None or not nav.position_ok:
            self._say(SEVERITY_CRITICAL, "RTL denied: no home position")
            return DENIED
        self._target, text = self._rtl.start(
            nav,
            self.home,
            self._settings().rtl_return_alt_m,
            self.missions.items(MissionType.RALLY),
            origin_lla(nav),
        )
        self._yaw_sp = nav.yaw_rad
        self._set_mode(MainMode.AUTO, AutoSubMode.RTL)
        self._say(SEVERITY_INFO, text)
        return ACCEPTED

    def set_mode(self, main: int, sub: int) -> int:
        """MAV_CMD_DO_SET_MODE with PX4 custom main/sub modes."""
        if main == MainMode.AUTO:
            if sub == AutoSubMode.LOITER:
                if self.in_air:
                    self._hold_here()
                else:
                    self._set_mode(MainMode.AUTO, AutoSubMode.LOITER)
                return ACCEPTED
            if sub == AutoSubMode.TAKEOFF:
                return self.takeoff(None)
            if sub == AutoSubMode.LAND:
                return self.land() if self.in_air else self._accept_on_ground(sub)
            if sub == AutoSubMode.RTL:
                if not self.in_air:
                    return self._accept_on_ground(sub)
                return self.return_to_launch()
            if sub == AutoSubMode.MISSION:
                return self._start_mission()
            return DENIED
        if main == MainMode.OFFBOARD:
            return self._start_offboard()
        if main in _MANUAL_MODES:
            self._say(SEVERITY_CRITICAL, "Manual modes denied: no RC or manual control input")
            return DENIED
        return DENIED

    def _accept_on_ground(self, sub: AutoSubMode) -> int:
        # On the ground RTL/LAND are already done: stay landed (auto-disarm follows).
        self._set_mode(MainMode.AUTO, sub)
        return ACCEPTED

    def reposition(self, target_ned_m: np.ndarray, yaw_rad: float, speed_m_s: float) -> int:
        """Go to a point in the local NED frame (NaN components keep the current target)."""
        if not self.armed or not self.in_air:
            self._say(SEVERITY_WARNING, "Reposition denied: not flying")
            return DENIED
        self._target = reposition_target(self._target, self._position(), target_ned_m)
        if math.isfinite(yaw_rad):
            self._yaw_sp = yaw_rad
        if math.isfinite(speed_m_s) and speed_m_s > 0:
            self._speed_override_m_s = speed_m_s
        self._set_mode(MainMode.AUTO, AutoSubMode.LOITER)
        return ACCEPTED

    def change_speed(self, speed_m_s: float) -> int:
        """Ground speed for AUTO modes; -1 or NaN restores MPC_XY_CRUISE."""
        self._speed_override_m_s = (
            speed_m_s if math.isfinite(speed_m_s) and speed_m_s > 0 else math.nan
        )
        return ACCEPTED

    def terminate(self) -> int:
        """Flight termination: motors off now (PX4 then reports MAV_STATE_FLIGHT_TERMINATION)."""
        if self.armed:
            self._disarm("Flight termination active")
            self.killed = True
            self.terminated = True
        return ACCEPTED

    # -- offboard ------------------------------------------------------------------------------
    def offboard_setpoint(self, setpoint: OffboardSetpoint) -> bool:
        """A SET_POSITION_TARGET_* / SET_ATTITUDE_TARGET arrived (local NED, decoded).

        Returns False if it was ignored (a thrust alone without an attitude setpoint).
        """
        return self.offboard.receive(setpoint, self._now())

    def _offboard_fresh(self, p: CommanderParams) -> bool:
        return self.offboard.fresh(self._now(), p.offboard_loss_timeout_s)

    def _start_offboard(self) -> int:
        """Enter Offboard: only with a fresh setpoint stream and what its setpoints need."""
        if not self._offboard_fresh(self._settings()):
            self._say(SEVERITY_CRITICAL, "Switching to Offboard denied: no offboard setpoints")
            return DENIED
        setpoint = self.offboard.setpoint
        assert setpoint is not None
        if setpoint.needs_position and not (self._last is not None and self._last.position_ok):
            self._say(SEVERITY_CRITICAL, "Switching to Offboard denied: no local position")
            return DENIED
        self._set_mode(MainMode.OFFBOARD)
        self._offboard_fallback = None
        return ACCEPTED

    def _check_offboard_signal(self, p: CommanderParams) -> None:
        """Offboard-loss failsafe (COM_OF_LOSS_T, COM_OBL_RC_ACT) and its recovery."""
        if not self.armed:
            self._offboard_fallback = None
            return
        fresh = self._offboard_fresh(p)
        if self.main_mode == MainMode.OFFBOARD and not fresh:
            action = loss_action(p.offboard_loss_action)
            self._say(
                SEVERITY_CRITICAL,
                f"Offboard signal lost: switching to {ACTION_NAMES[action]}",
            )
            self._take_action(action)
            self._offboard_fallback = (self.main_mode, self.sub_mode) if self.armed else None
        elif (
            fresh
            and self._offboard_fallback is not None
            and self._offboard_fallback == (self.main_mode, self.sub_mode)
        ):
            self._say(SEVERITY_INFO, "Offboard signal regained")
            self._set_mode(MainMode.OFFBOARD)
            self._offboard_fallback = None

    # -- missions, geofence, rally -------------------------------------------------------------
    def _start_mission(self) -> int:
        """Mission mode: fly the stored mission from its current item (taking off if landed)."""
        if not self.mission.valid:
            self._say(SEVERITY_CRITICAL, "Switching to Mission is currently not available")
            return TEMPORARILY_REJECTED
        if self.sub_mode == AutoSubMode.MISSION and self.mission.state == MissionState.ACTIVE:
            return ACCEPTED
        self._set_mode(MainMode.AUTO, AutoSubMode.MISSION)
        if self.armed:
            self.mission.activate(landed=not self.in_air)
            if not self.in_air:
                self.landed_state = LandedState.TAKEOFF
        return ACCEPTED

    def start_mission(self, first_seq: int) -> int:
        """MAV_CMD_MISSION_START as PX4: arm if needed, fly from ``first_seq`` (-1: current).

        On the ground the mission takes off: this, not a plain arm, is how PX4 starts a mission
        from the ground with one command.
        """
        if not self.mission.valid:
            self._say(SEVERITY_CRITICAL, "Mission start denied! No valid mission")
            return DENIED
        if first_seq >= len(self.mission.items):
            return DENIED
        if not self.armed and self.arm(force=False) != ACCEPTED:
            self._say(SEVERITY_CRITICAL, "Mission start denied")
            return TEMPORARILY_REJECTED
        if first_seq >= 0:
            self.mission.set_current(first_seq)
        return self._start_mission()

    def upload_mission(self, kind: MissionType, items: tuple[MissionItem, ...]) -> int:
        """Store a plan (upload or clear), rebuild the fence, re-check the mission."""
        kind = MissionType(kind)
        self.missions.replace(kind, items)
        if kind == MissionType.FENCE:
            self.fence = build_fence(items)  # the transfer checked it is well formed
        if kind == MissionType.RALLY:
            return MAV_MISSION_ACCEPTED
        running = self.sub_mode == AutoSubMode.MISSION and self.mission.state == MissionState.ACTIVE
        self.mission.load(self.missions.items(MissionType.MISSION), self._mission_feasible())
        if running:
            if self.mission.valid:
                self.mission.activate(landed=not self.in_air)
            elif self.in_air:
                self._hold_here()
        return MAV_MISSION_ACCEPTED

    def _mission_feasible(self) -> bool:
        """PX4's feasibility check of the stored mission; announces why it is refused."""
        return mission_feasible(
            self.missions.items(MissionType.MISSION),
            self.home,
            origin_lla(self._last),
            self.fence,
            self._settings(),
            self._say,
        )

    def set_mission_current(self, seq: int) -> bool:
        """MISSION_SET_CURRENT: continue the mission at item ``seq``."""
        return self.mission.set_current(seq)

    def mission_status(self) -> tuple[int, int, int]:
        """(current seq, total items or 65535 without a mission, MISSION_STATE), as PX4."""
        total = len(self.mission.items)
        state = self.mission.state
        return (self.mission.current, total if state != MissionState.NO_MISSION else 0xFFFF, state)

    def gcs_heartbeat(self) -> None:
        """A ground-station HEARTBEAT arrived (data-link-loss failsafe)."""
        self._gcs_heard_s = self._now()

    @property
    def fence_enabled(self) -> bool:
        """A geofence is configured (areas, or a maximum distance or height)."""
        return self._fence_enabled(self._settings())

    def _fence_enabled(self, p: CommanderParams) -> bool:
        return not self.fence.empty or p.fence_max_hor_dist_m > 0 or p.fence_max_ver_dist_m > 0

    # -- the 50 Hz tick --------------------------------------------------------------------------
    def update(self, nav: NavInput) -> NavOutput:
        """Advance land detection and the active mode; return the controller setpoint."""
        dt_s = nav.time_s - self._last.time_s if self._last is not None else 0.0
        if dt_s > 0.0:
            self._dt_s = dt_s
        self._last = nav
        p = self._settings()
        if self.home is None and nav.position_ok:
            self.set_home_here()
        descending = self._descending
        self.landed_state = self._land_detector.update(
            nav, self.landed_state, self.armed, descending, self.home
        )
        if self.landed_state == _LANDING and not descending:
            self.landed_state = _IN_AIR  # Land (or RTL's descent) was left in the air
        self._check_failsafes(nav, descending, p)
        self._check_offboard_signal(p)
        out = NavOutput(yaw_rad=self._yaw_sp)
        out.max_speed_xy_m_s = self._cruise_m_s(p)
        out.max_speed_up_m_s = p.auto_climb_speed_m_s
        out.max_speed_down_m_s = p.auto_descent_speed_m_s
        if not self.armed:
            return out
        offboard = self.main_mode == _OFFBOARD
        if offboard and self.landed_state in (_ON_GROUND, _TAKING_OFF):
            # Offboard takes off when its setpoint lifts the vehicle, and gives up if it stops.
            climb = self.offboard.wants_climb(nav.position_ned_m, self._hover_thrust(p))
            self.landed_state = _TAKING_OFF if climb else _ON_GROUND
        grounded = self.landed_state == _ON_GROUND
        if grounded and self.sub_mode != _SUB_TAKEOFF:
            if self.sub_mode == _SUB_MISSION and self.mission.landing:
                self._mission_setpoint(nav, NavOutput(), p)  # the landing item is complete
            self._check_preflight_disarm(nav, p)
            return out
        out.active = True
        out.smooth = not offboard
        out.position_ned_m = self._target.copy()
        sub = self.sub_mode
        if offboard:
            self.offboard.output(nav, out, dt_s, self._hover_thrust(p), p)
            self._target = self._position()
            self._yaw_sp = out.yaw_rad if math.isfinite(out.yaw_rad) else nav.yaw_rad
        elif sub == _SUB_TAKEOFF:
            out.max_speed_up_m_s = p.takeoff_speed_m_s
            if takeoff_reached(nav, self._target) and self.in_air:
                self._set_mode(MainMode.AUTO, AutoSubMode.LOITER)
                self._say(SEVERITY_INFO, "Takeoff complete, holding")
        elif sub == _SUB_LAND:
            self._land_setpoint(nav, out, p)
        elif sub == _SUB_RTL:
            if self._rtl.phase is _RTL_LAND:
                self._land_setpoint(nav, out, p)
            else:
                self._target = self._rtl.step(nav, self._target, p.acceptance_radius_m)
        elif sub == _SUB_MISSION:
            self._mission_setpoint(nav, out, p)
        if self.landed_state == _TAKING_OFF and not offboard:
            self._takeoff_ramp.apply(nav, out, p)
        else:
            self._takeoff_ramp.start_s = None
        return out

    def _mission_setpoint(self, nav: NavInput, out: NavOutput, p: CommanderParams) -> None:
        """One tick of the mission: the executor's leg becomes the controller setpoint."""
        home = self.home
        origin = origin_lla(self._last)
        if home is None or origin is None:
            return
        mission = self.mission
        leg = mission_leg(mission, nav, self.landed_state == _ON_GROUND, home, origin, p)
        speed_m_s = take_events(mission, self.mission_reached, self.component_commands, self._say)
        if speed_m_s is not None:
            self.change_speed(speed_m_s)
        if leg.kind == LegKind.RTL:
            if self.return_to_launch() != ACCEPTED:
                self.land()
            return
        target = np.where(np.isfinite(leg.target_ned_m), leg.target_ned_m, nav.position_ned_m)
        self._target = target
        if math.isfinite(leg.yaw_rad):
            self._yaw_sp = leg.yaw_rad
            out.yaw_rad = leg.yaw_rad
        out.position_ned_m = target.copy()
        if leg.kind == LegKind.LAND and over_landing_point(target, nav, p):
            self._land_setpoint(nav, out, p)  # over the landing point at the leg's altitude

    def _land_setpoint(self, nav: NavInput, out: NavOutput, p: CommanderParams) -> None:
        """Land's descent (Land, RTL's last phase, a mission landing); the landed state follows."""
        home = self.home
        height_m = float(home.position_ned_m[2] - nav.position_ned_m[2]) if home else 0.0
        descend(out, height_m, p)
        if self.landed_state == _IN_AIR:
            self.landed_state = _LANDING

    @property
    def _descending(self) -> bool:
        """In the final descent of LAND, RTL or a mission landing."""
        sub = self.sub_mode
        return (
            sub == _SUB_LAND
            or (sub == _SUB_RTL and self._rtl.phase is _RTL_LAND)
            or (sub == _SUB_MISSION and self.mission.landing)
        )

    # -- failsafes, auto-disarm ------------------------------------------------------------------
    def _check_failsafes(self, nav: NavInput, descending: bool, p: CommanderParams) -> None:
        """Geofence breach, data link, battery and position: announce, then act."""
        self.fence_breached = self._breaching_fence(nav, p)
        monitor = self.failsafe
        action = monitor.update(
            FailsafeInput(
                time_s=nav.time_s,
                armed=self.armed,
                in_air=self.in_air and self.landed_state != _TAKING_OFF,
                landing=descending,
                battery_remaining=nav.battery_remaining,
                position_ok=nav.position_ok,
                fence_breached=self.fence_breached,
                gcs_heard_s=self._gcs_heard_s,
            )
        )
        for severity, text in monitor.texts:
            self._say(severity, text)
        monitor.texts.clear()
        self._take_action(action)

    def _take_action(self, action: Action) -> None:
        """Carry out a failsafe action (on the ground: the mode only, auto-disarm follows)."""
        if action == Action.HOLD:
            self._hold_here()
        elif action == Action.RTL:
            if not self.in_air:
                self._accept_on_ground(AutoSubMode.RTL)
            elif self.return_to_launch() != ACCEPTED:
                self.land()
        elif action == Action.LAND:
            if self.in_air:
                self.land()
            else:
                self._accept_on_ground(AutoSubMode.LAND)
        elif action == Action.DISARM:
            self.disarm(force=True)
        elif action == Action.TERMINATE:
            self.terminate()

    def _breaching_fence(self, nav: NavInput, p: CommanderParams) -> bool:
        """A geofence is configured and the vehicle is outside it (:func:`outside_fence`)."""
        if not (self._fence_enabled(p) and nav.position_ok and self.home is not None):
            return False
        return outside_fence(nav, self.home.position_ned_m, self.fence, p)

    def _check_preflight_disarm(self, nav: NavInput, p: CommanderParams) -> None:
        """Auto-disarm on the ground: COM_DISARM_LAND after a landing, else COM_DISARM_PRFLT."""
        ground_since = self._land_detector.ground_since_s
        since = ground_since if ground_since is not None else self._arm_time_s
        since = max(since, self._arm_time_s)
        landed_after_flight = ground_since is not None and ground_since >= self._arm_time_s
        limit = p.disarm_land_s if landed_after_flight else p.disarm_preflight_s
        if limit > 0 and nav.time_s - since >= limit:
            self._disarm("Disarmed by landing" if landed_after_flight else "Disarmed: no takeoff")
