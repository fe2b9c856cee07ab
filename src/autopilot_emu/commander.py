"""Commander and navigator of one vehicle: arming, modes, land detection, and setpoints.

PX4 splits this between commander (arming, mode switching, failsafes), navigator (AUTO modes)
and land_detector; here one small state machine per vehicle holds all three, because all of it
runs at the 50 Hz navigation rate on a handful of numbers. It is pure logic: it reads the estimate
and parameters, and writes position setpoints for the batched controllers.

Results are MAV_RESULT values: 0 accepted, 1 temporarily rejected, 2 denied.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from autopilot_emu import geodesy
from autopilot_emu.control.trajectory import braking_distance, hold_point
from autopilot_emu.estimator import GRAVITY_M_S2
from autopilot_emu.failsafe import ACTION_NAMES, Action, FailsafeInput, FailsafeMonitor
from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.mission.executor import LegKind, MissionExecutor, StepInput, Tolerances
from autopilot_emu.mission.feasibility import (
    PlanContext,
    mission_feasibility,
)
from autopilot_emu.mission.geofence import Fence, build_fence
from autopilot_emu.mission.items import MissionItem, MissionState, MissionStore, MissionType
from autopilot_emu.modes import AutoSubMode, LandedState, MainMode
from autopilot_emu.modes.offboard import OffboardControl, OffboardSetpoint, loss_action
from autopilot_emu.params import ParamStore

ACCEPTED, TEMPORARILY_REJECTED, DENIED = 0, 1, 2
SEVERITY_CRITICAL, SEVERITY_WARNING, SEVERITY_NOTICE, SEVERITY_INFO = 2, 4, 5, 6
FORCE_MAGIC = 21196
"""MAV_CMD_COMPONENT_ARM_DISARM param2 that forces (kills) regardless of state."""
MIN_TAKEOFF_HEIGHT_M = 1.0
"""Lowest take-off height above the ground, m: a take-off to or below the ground (a NAV_TAKEOFF
with a low param7, MIS_TAKEOFF_ALT 0) would leave the vehicle "taking off" on the ground."""
MAV_MISSION_ACCEPTED = 0


class RtlPhase(Enum):
    """Phases of Return-To-Launch."""

    CLIMB = "climb"
    RETURN = "return"
    LAND = "land"


# Enum members as module constants: an enum attribute look-up costs ~0.3 us in Python 3.11 and
# the 50 Hz tick compares states a dozen times.
_ON_GROUND, _TAKING_OFF = LandedState.ON_GROUND, LandedState.TAKEOFF
_IN_AIR, _LANDING = LandedState.IN_AIR, LandedState.LANDING
_SUB_TAKEOFF, _SUB_MISSION = AutoSubMode.TAKEOFF, AutoSubMode.MISSION
_SUB_LAND, _SUB_RTL = AutoSubMode.LAND, AutoSubMode.RTL
_OFFBOARD = MainMode.OFFBOARD
_RTL_LAND = RtlPhase.LAND

_MIN_THRUST_LANDED = 0.1
"""Collective thrust below which a still vehicle without a learned hover thrust is landed (just
above the position controller's 0.05 floor)."""


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


class Commander:
    """Arming, PX4 modes, navigator and land detector for one vehicle."""

    def __init__(self, params: ParamStore) -> None:
        self.params = params
        self.armed = False
        self.main_mode = MainMode.AUTO
        self.sub_mode = AutoSubMode.LOITER
        self.landed_state = LandedState.ON_GROUND
        self.home: Home | None = None
        self.status_texts: list[tuple[int, str]] = []
        self._target = np.full(3, np.nan)
        self._yaw_sp = 0.0
        self._speed_override_m_s = math.nan
        self._rtl_phase = RtlPhase.CLIMB
        self._rtl_alt_ned_z = 0.0
        self._arm_time_s = 0.0
        self._ground_since_s: float | None = None
        self._landed_candidate_s: float | None = None
        self._last: NavInput | None = None
        self._dt_s = 0.004
        self.trajectory_state: Callable[[], TrajectoryState | None] | None = None
        """The fleet's view of this vehicle's smoothed setpoint (None while it is not smoothing):
        Hold stops where that setpoint can stop."""
        self.killed = False
        self.missions = MissionStore()
        self.mission = MissionExecutor()
        self.mission_reached: list[int] = []
        self.component_commands: list[ComponentCommand] = []
        """Commands for the vehicle's other components (mission camera items), not yet sent."""
        self.fence = Fence()
        self.fence_breached = False
        self.failsafe = FailsafeMonitor(params)
        self._gcs_heard_s: float | None = None
        self._rtl_dest_ned = np.zeros(2)
        self.offboard = OffboardControl()
        self._takeoff_ramp_start_s: float | None = None
        self._offboard_fallback: tuple[MainMode, AutoSubMode] | None = None
        """Mode the offboard-loss failsafe switched to; Offboard resumes from it when the
        setpoint stream comes back (PX4's mode fallback clears with its condition)."""

    # -- helpers ------------------------------------------------------------------------------
    def _say(self, severity: int, text: str) -> None:
        self.status_texts.append((severity, text))

    @property
    def in_air(self) -> bool:
        """True from takeoff detection until landing is detected."""
        return self.landed_state != _ON_GROUND

    def _hover_thrust(self) -> float:
        """The hover thrust in use: the estimate the fleet passes in, else MPC_THR_HOVER."""
        if self._last is not None and math.isfinite(self._last.hover_thrust):
            return self._last.hover_thrust
        return float(self.params.get("MPC_THR_HOVER"))

    def _cruise_m_s(self) -> float:
        """Horizontal speed of the auto modes: the speed override, else MPC_XY_CRUISE."""
        cruise = self._speed_override_m_s
        if not math.isfinite(cruise):
            cruise = float(self.params.get("MPC_XY_CRUISE"))
        return min(cruise, float(self.params.get("MPC_XY_VEL_MAX")))

    def _now(self) -> float:
        return self._last.time_s if self._last else 0.0

    def _position(self) -> np.ndarray:
        return self._last.position_ned_m.copy() if self._last else np.zeros(3)

    def _set_mode(self, main: MainMode, sub: AutoSubMode = AutoSubMode.NONE) -> None:
        if self.sub_mode == AutoSubMode.MISSION and sub != AutoSubMode.MISSION:
            self.mission.pause()
        self.main_mode, self.sub_mode = main, sub

    def _hold_here(self) -> None:
        """Hold at the braking point: the current position plus the distance it takes to stop.

        As PX4's Loiter (Navigator::calculate_breaking_stop), so that a Hold commanded at speed
        does not fly back to where it was asked; the distance is the jerk-limited trajectory's
        stopping distance with MPC_ACC_HOR and MPC_JERK_AUTO. PX4's estimate assumes a steady
        speed; when the smoothed setpoint is still speeding up or runs ahead of the vehicle it
        stops further out, and the hold point is then where it stops, so the vehicle does not
        turn back after braking.
        """
        self._target = self._position()
        if self._last is not None and self.in_air:
            vel = self._last.velocity_ned_m_s[:2]
            speed = float(np.hypot(vel[0], vel[1]))
            acc = float(self.params.get("MPC_ACC_HOR"))
            jerk = float(self.params.get("MPC_JERK_AUTO"))
            if speed > 1e-6:
                self._target[:2] += vel * (float(braking_distance(speed, acc, jerk)) / speed)
                state = self.trajectory_state() if self.trajectory_state is not None else None
                if state is not None:
                    stop = hold_point(*state, self._cruise_m_s(), acc, jerk, self._dt_s)
                    here = self._last.position_ned_m[:2]
                    if np.dot(stop - here, vel) > np.dot(self._target[:2] - here, vel):
                        self._target[:2] = stop
        self._yaw_sp = self._last.yaw_rad if self._last else 0.0
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
        keep_offboard = self.main_mode == MainMode.OFFBOARD and self._offboard_fresh()
        if not keep_offboard and (
            self.main_mode != MainMode.AUTO
            or self.sub_mode not in (AutoSubMode.LOITER, AutoSubMode.LAND)
        ):
            self._hold_here()
        self.armed = True
        self.killed = False
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

        On the ground the target is at least MIS_TAKEOFF_ALT (and never less than
        :data:`MIN_TAKEOFF_HEIGHT_M`) above the ground; in the air a target below the vehicle
        keeps the current altitude, as PX4's takeoff does.
        """
        if not self.armed:
            self._say(SEVERITY_CRITICAL, "Takeoff denied: disarmed")
            return DENIED
        if self._last is None or not self._last.position_ok or self.home is None:
            return TEMPORARILY_REJECTED
        nav = self._last
        here_amsl = nav.origin_alt_amsl_m - float(nav.position_ned_m[2])
        default_height = max(float(self.params.get("MIS_TAKEOFF_ALT")), MIN_TAKEOFF_HEIGHT_M)
        explicit = alt_amsl_m is not None and math.isfinite(alt_amsl_m)
        if not explicit:
            alt_amsl_m = self.home.alt_amsl_m + default_height
        if not self.in_air and alt_amsl_m < here_amsl + default_height:
            if explicit:
                self._say(
                    SEVERITY_WARNING, f"Using minimum takeoff altitude: {default_height:.2f} m"
                )
            alt_amsl_m = here_amsl + default_height
        elif self.in_air and alt_amsl_m < here_amsl:
            alt_amsl_m = here_amsl
            self._say(SEVERITY_INFO, "Already higher than takeoff altitude")
        target = self._position()
        target[2] = nav.origin_alt_amsl_m - alt_amsl_m
        self._target = target
        self._yaw_sp = nav.yaw_rad
        self._set_mode(MainMode.AUTO, AutoSubMode.TAKEOFF)
        if not self.in_air:
            self.landed_state = LandedState.TAKEOFF
        self._say(
            SEVERITY_INFO,
            f"Takeoff to {alt_amsl_m - self.home.alt_amsl_m:.1f} m above home",
        )
        return ACCEPTED

    def land(self) -> int:
        """Descend and land at the current position."""
        if not self.armed:
            return DENIED
        self._target = self._position()
        self._target[2] = np.nan
        self._yaw_sp = self._last.yaw_rad if self._last else 0.0
        self._set_mode(MainMode.AUTO, AutoSubMode.LAND)
        self._say(SEVERITY_INFO, "Landing at current position")
        return ACCEPTED

    def return_to_launch(self) -> int:
        """Climb to RTL_RETURN_ALT, fly home, land (PX4 RTL)."""
        if self.home is None or self._last is None or not self._last.position_ok:
            self._say(SEVERITY_CRITICAL, "RTL denied: no home position")
            return DENIED
        rtl_alt = self.home.alt_amsl_m + float(self.params.get("RTL_RETURN_ALT"))
        self._rtl_alt_ned_z = min(
            self._last.position_ned_m[2], self._last.origin_alt_amsl_m - rtl_alt
        )
        self._rtl_phase = RtlPhase.CLIMB
        self._target = self._position()
        self._target[2] = self._rtl_alt_ned_z
        self._yaw_sp = self._last.yaw_rad
        self._set_mode(MainMode.AUTO, AutoSubMode.RTL)
        self._rtl_dest_ned, rally = self._rtl_destination()
        above_home = self._last.origin_alt_amsl_m - self._rtl_alt_ned_z - self.home.alt_amsl_m
        where = f"rally point {rally + 1}" if rally is not None else "home"
        self._say(SEVERITY_INFO, f"RTL: return to {where} at {above_home:.0f} m")
        return ACCEPTED

    def _rtl_destination(self) -> tuple[np.ndarray, int | None]:
        """Home or the closest rally point, whichever is nearer (horizontal NED, m)."""
        assert self.home is not None and self._last is not None
        here = self._last.position_ned_m[:2]
        best, best_index = self.home.position_ned_m[:2].copy(), None
        best_dist = float(np.hypot(*(best - here)))
        origin = self._origin()
        if origin is None:
            return best, None
        for index, item in enumerate(self.missions.items(MissionType.RALLY)):
            point = geodesy.geodetic_to_ned(np.array([item.lat_deg, item.lon_deg, 0.0]), origin)
            dist = float(np.hypot(*(point[:2] - here)))
            if dist < best_dist:
                best, best_index, best_dist = point[:2], index, dist
        return best, best_index

    def _origin(self) -> np.ndarray | None:
        """The NED origin as (lat, lon, alt AMSL), None before the first fix."""
        nav = self._last
        if nav is None or not math.isfinite(nav.origin_lat_lon_deg[0]):
            return None
        return np.array([*nav.origin_lat_lon_deg, nav.origin_alt_amsl_m])

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
        if main in (
            MainMode.POSCTL,
            MainMode.ALTCTL,
            MainMode.MANUAL,
            MainMode.STABILIZED,
            MainMode.ACRO,
            MainMode.RATTITUDE,
        ):
            self._say(SEVERITY_CRITICAL, "Manual modes denied: no RC or manual control input")
            return DENIED
        return DENIED

    # -- offboard ------------------------------------------------------------------------------
    def offboard_setpoint(self, setpoint: OffboardSetpoint) -> bool:
        """A SET_POSITION_TARGET_* / SET_ATTITUDE_TARGET arrived (local NED, decoded).

        Returns False if it was ignored (a thrust alone without an attitude setpoint).
        """
        return self.offboard.receive(setpoint, self._now())

    def _offboard_fresh(self) -> bool:
        return self.offboard.fresh(self._now(), self.params.floats()["COM_OF_LOSS_T"])

    def _start_offboard(self) -> int:
        """Enter Offboard: only with a fresh setpoint stream and what its setpoints need."""
        if not self._offboard_fresh():
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

    def _check_offboard_signal(self) -> None:
        """Offboard-loss failsafe (COM_OF_LOSS_T, COM_OBL_RC_ACT) and its recovery."""
        if not self.armed:
            self._offboard_fallback = None
            return
        fresh = self._offboard_fresh()
        if self.main_mode == MainMode.OFFBOARD and not fresh:
            action = loss_action(int(self.params.get("COM_OBL_RC_ACT")))
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

    def _offboard_output(self, nav: NavInput, out: NavOutput, dt_s: float) -> None:
        """Offboard mode: the last setpoint becomes the controller target."""
        p = self.params
        target = self.offboard.target(nav.position_ned_m, nav.yaw_rad, dt_s, self._hover_thrust())
        out.position_ned_m = target.position_ned_m
        out.velocity_ff_m_s = target.velocity_ff_m_s
        out.acceleration_ff_m_s2 = target.acceleration_ff_m_s2
        out.yaw_rad = target.yaw_rad
        out.attitude_wxyz = target.attitude_wxyz
        out.body_rates_rad_s = target.body_rates_rad_s
        out.thrust = target.thrust
        out.max_speed_xy_m_s = float(p.get("MPC_XY_VEL_MAX"))
        out.max_speed_up_m_s = float(p.get("MPC_Z_VEL_MAX_UP"))
        out.max_speed_down_m_s = float(p.get("MPC_Z_VEL_MAX_DN"))
        self._target = self._position()
        self._yaw_sp = target.yaw_rad if math.isfinite(target.yaw_rad) else nav.yaw_rad

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

    # -- missions, geofence, rally -------------------------------------------------------------
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
        items = self.missions.items(MissionType.MISSION)
        if not items:
            return False
        home = None
        if self.home is not None and (origin := self._origin()) is not None:
            lat, lon, _ = geodesy.ned_to_geodetic(self.home.position_ned_m, origin)
            home = (float(lat), float(lon), self.home.alt_amsl_m)
        p = self.params
        result = mission_feasibility(
            items,
            PlanContext(
                home_lat_lon_alt=home,
                fence=self.fence,
                max_hor_dist_m=float(p.get("GF_MAX_HOR_DIST")),
                max_ver_dist_m=float(p.get("GF_MAX_VER_DIST")),
                dist_1wp_m=float(p.get("MIS_DIST_1WP")),
            ),
        )
        for warning in result.warnings:
            self._say(SEVERITY_WARNING, warning)
        if result.problem is not None:
            self._say(SEVERITY_CRITICAL, result.problem)
            return False
        return True

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
        p = self.params.floats()
        return not self.fence.empty or p["GF_MAX_HOR_DIST"] > 0 or p["GF_MAX_VER_DIST"] > 0

    def _accept_on_ground(self, sub: AutoSubMode) -> int:
        # On the ground RTL/LAND are already done: stay landed (auto-disarm follows).
        self._set_mode(MainMode.AUTO, sub)
        return ACCEPTED

    def reposition(self, target_ned_m: np.ndarray, yaw_rad: float, speed_m_s: float) -> int:
        """Go to a point in the local NED frame (NaN components keep the current target)."""
        if not self.armed or not self.in_air:
            self._say(SEVERITY_WARNING, "Reposition denied: not flying")
            return DENIED
        base = self._target if np.isfinite(self._target).all() else self._position()
        self._target = np.where(np.isfinite(target_ned_m), target_ned_m, base)
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
        """Flight termination: motors off now."""
        if self.armed:
            self._disarm("Flight termination active")
            self.killed = True
        return ACCEPTED

    # -- the 50 Hz tick --------------------------------------------------------------------------
    def update(self, nav: NavInput) -> NavOutput:
        """Advance land detection and the active mode; return the controller setpoint."""
        dt_s = nav.time_s - self._last.time_s if self._last is not None else 0.0
        if dt_s > 0.0:
            self._dt_s = dt_s
        self._last = nav
        p = self.params.floats()
        if self.home is None and nav.position_ok:
            self.set_home_here()
        self._detect_landing(nav)
        if self.landed_state == _LANDING and not self._descending:
            self.landed_state = _IN_AIR  # Land (or RTL's descent) was left in the air
        self._check_failsafes(nav)
        self._check_offboard_signal()
        out = NavOutput(yaw_rad=self._yaw_sp)
        out.max_speed_xy_m_s = self._cruise_m_s()
        out.max_speed_up_m_s = p["MPC_Z_V_AUTO_UP"]
        out.max_speed_down_m_s = p["MPC_Z_V_AUTO_DN"]
        if not self.armed:
            return out
        offboard = self.main_mode == _OFFBOARD
        if offboard and self.landed_state in (_ON_GROUND, _TAKING_OFF):
            # Offboard takes off when its setpoint lifts the vehicle, and gives up if it stops.
            climb = self.offboard.wants_climb(nav.position_ned_m, self._hover_thrust())
            self.landed_state = _TAKING_OFF if climb else _ON_GROUND
        grounded = self.landed_state == _ON_GROUND
        if grounded and self.sub_mode != _SUB_TAKEOFF:
            if self.sub_mode == _SUB_MISSION and self.mission.landing:
                self._mission_setpoint(nav, NavOutput())  # the landing item is complete
            self._check_preflight_disarm(nav)
            return out
        out.active = True
        out.smooth = not offboard
        out.position_ned_m = self._target.copy()
        sub = self.sub_mode
        if offboard:
            self._offboard_output(nav, out, dt_s)
        elif sub == _SUB_TAKEOFF:
            out.max_speed_up_m_s = p["MPC_TKO_SPEED"]
            if abs(nav.position_ned_m[2] - self._target[2]) < 0.3 and self.in_air:
                self._set_mode(MainMode.AUTO, AutoSubMode.LOITER)
                self._say(SEVERITY_INFO, "Takeoff complete, holding")
        elif sub == _SUB_LAND:
            self._land_setpoint(nav, out)
        elif sub == _SUB_RTL:
            self._rtl_setpoint(nav, out)
        elif sub == _SUB_MISSION:
            self._mission_setpoint(nav, out)
        if self.landed_state == _TAKING_OFF and not offboard:
            self._takeoff_ramp(nav, out)
        else:
            self._takeoff_ramp_start_s = None
        return out

    def _takeoff_ramp(self, nav: NavInput, out: NavOutput) -> None:
        """Until lift-off, ramp the climb-rate setpoint instead of flying the trajectory.

        As PX4's Takeoff (MPC_TKO_RAMP_T): the vertical velocity setpoint starts where the
        velocity loop asks for zero thrust (g / MPC_Z_VEL_P_ACC downwards) and ramps linearly to
        MPC_TKO_SPEED upwards, so a wrong MPC_THR_HOVER guess cannot throw the vehicle up.
        """
        p = self.params.floats()
        if self._takeoff_ramp_start_s is None:
            self._takeoff_ramp_start_s = nav.time_s
        ramp_s = max(p["MPC_TKO_RAMP_T"], 1e-3)
        frac = min(max((nav.time_s - self._takeoff_ramp_start_s) / ramp_s, 0.0), 1.0)
        start = GRAVITY_M_S2 / max(p["MPC_Z_VEL_P_ACC"], 0.1)
        end = -p["MPC_TKO_SPEED"]
        out.position_ned_m[2] = np.nan
        out.velocity_ff_m_s = np.array([0.0, 0.0, start + frac * (end - start)])
        out.max_speed_down_m_s = max(out.max_speed_down_m_s, start)
        out.smooth = False

    def _mission_setpoint(self, nav: NavInput, out: NavOutput) -> None:
        """One tick of the mission: the executor's leg becomes the controller setpoint."""
        home = self.home
        origin = self._origin()
        if home is None or origin is None:
            return
        p = self.params

        def to_ned(lat: float, lon: float, alt: float) -> np.ndarray:
            return geodesy.geodetic_to_ned(np.array([lat, lon, alt]), origin)

        mission = self.mission
        leg = mission.step(
            StepInput(
                time_s=nav.time_s,
                position_ned_m=nav.position_ned_m,
                yaw_rad=nav.yaw_rad,
                landed=self.landed_state == LandedState.ON_GROUND,
                home_alt_amsl_m=home.alt_amsl_m,
                tolerances=Tolerances(
                    acceptance_radius_m=float(p.get("NAV_ACC_RAD")),
                    altitude_radius_m=float(p.get("NAV_MC_ALT_RAD")),
                    takeoff_alt_m=max(float(p.get("MIS_TAKEOFF_ALT")), MIN_TAKEOFF_HEIGHT_M),
                ),
                to_ned=to_ned,
            )
        )
        self.mission_reached.extend(mission.reached)
        mission.reached.clear()
        self.component_commands.extend(mission.component_commands)
        mission.component_commands.clear()
        for text in mission.texts:
            self._say(SEVERITY_INFO, text)
        mission.texts.clear()
        if mission.speed_m_s is not None:
            self.change_speed(mission.speed_m_s)
            mission.speed_m_s = None
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
        if leg.kind == LegKind.LAND:
            # Fly over the landing point at the leg's altitude, then descend.
            offset = float(np.hypot(*(target[:2] - nav.position_ned_m[:2])))
            if offset <= float(p.get("NAV_ACC_RAD")):
                self._land_setpoint(nav, out)

    # -- failsafes -------------------------------------------------------------------------------
    def _check_failsafes(self, nav: NavInput) -> None:
        """Geofence breach, data link, battery and position: announce, then act."""
        self.fence_breached = self._breaching_fence(nav)
        monitor = self.failsafe
        action = monitor.update(
            FailsafeInput(
                time_s=nav.time_s,
                armed=self.armed,
                in_air=self.in_air and self.landed_state != _TAKING_OFF,
                landing=self._descending,
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

    def _breaching_fence(self, nav: NavInput) -> bool:
        """Outside the geofence areas, or beyond GF_MAX_HOR_DIST / GF_MAX_VER_DIST of home."""
        if not (self.fence_enabled and nav.position_ok and self.home is not None):
            return False
        p = self.params.floats()
        offset = nav.position_ned_m - self.home.position_ned_m
        max_hor = p["GF_MAX_HOR_DIST"]
        max_ver = p["GF_MAX_VER_DIST"]
        if 0 < max_hor < float(np.hypot(offset[0], offset[1])) or 0 < max_ver < -offset[2]:
            return True
        origin = self._origin()
        if self.fence.empty or origin is None:
            return False
        lat, lon, _ = geodesy.ned_to_geodetic(nav.position_ned_m, origin)
        return not self.fence.contains(float(lat), float(lon))

    @property
    def _descending(self) -> bool:
        """In the final descent of LAND, RTL or a mission landing."""
        return (
            self.sub_mode == _SUB_LAND
            or (self.sub_mode == _SUB_RTL and self._rtl_phase == _RTL_LAND)
            or (self.sub_mode == _SUB_MISSION and self.mission.landing)
        )

    def _land_setpoint(self, nav: NavInput, out: NavOutput) -> None:
        out.position_ned_m[2] = np.nan
        rel_alt = self._relative_alt(nav)
        p = self.params.floats()
        speed = p["MPC_Z_V_AUTO_DN"] if rel_alt > 10.0 else p["MPC_LAND_SPEED"]
        out.velocity_ff_m_s = np.array([0.0, 0.0, speed])
        if self.landed_state == LandedState.IN_AIR:
            self.landed_state = LandedState.LANDING

    def _rtl_setpoint(self, nav: NavInput, out: NavOutput) -> None:
        home = self.home
        assert home is not None
        if self._rtl_phase == RtlPhase.CLIMB:
            out.position_ned_m = self._target.copy()
            if nav.position_ned_m[2] - self._rtl_alt_ned_z < 0.5:
                self._rtl_phase = RtlPhase.RETURN
                dest = self._rtl_dest_ned
                self._target = np.array([dest[0], dest[1], self._rtl_alt_ned_z])
                self._say(SEVERITY_INFO, "RTL: returning")
        elif self._rtl_phase == RtlPhase.RETURN:
            out.position_ned_m = self._target.copy()
            dest = self._rtl_dest_ned
            dist = float(np.hypot(*(nav.position_ned_m[:2] - dest)))
            if (
                dist < float(self.params.get("NAV_ACC_RAD")) * 0.5
                and np.hypot(nav.velocity_ned_m_s[0], nav.velocity_ned_m_s[1]) < 0.5
            ):
                self._rtl_phase = RtlPhase.LAND
                self._target = np.array([dest[0], dest[1], np.nan])
                self._say(SEVERITY_INFO, "RTL: landing")
        else:
            out.position_ned_m = self._target.copy()
            self._land_setpoint(nav, out)

    def _relative_alt(self, nav: NavInput) -> float:
        if self.home is None:
            return 0.0
        return float(self.home.position_ned_m[2] - nav.position_ned_m[2])

    def _detect_landing(self, nav: NavInput) -> None:
        """PX4-like land detector: low thrust, no vertical motion, for a while."""
        vx, vy, vz_signed = nav.velocity_ned_m_s.tolist()
        vz = abs(vz_signed)
        vxy = math.hypot(vx, vy)
        if self.landed_state == _TAKING_OFF and not self.armed:
            self.landed_state = _ON_GROUND
            return
        if not self.in_air or self.landed_state == _TAKING_OFF:
            if (
                self.armed
                and self.landed_state == _TAKING_OFF
                and (self._relative_alt(nav) > 0.5 or vz_signed < -0.5)
            ):
                self.landed_state = _IN_AIR
            return
        descending = self._descending
        if math.isfinite(nav.hover_thrust):
            low_thrust = nav.thrust < 0.6 * nav.hover_thrust
        else:
            # No learned hover thrust yet (PX4's MPC_THR_HOVER default is a guess that can be
            # twice the real value): only thrust near the controller's minimum counts as low,
            # so a vehicle hovering on a light thrust is not "landed" in the air.
            low_thrust = nav.thrust < _MIN_THRUST_LANDED
        low_thrust = low_thrust or not self.armed
        # Without a position fix the horizontal velocity estimate drifts: judge by vertical only.
        still = vz < 0.3 and (vxy < 0.5 or not nav.position_ok)
        if still and (low_thrust or (descending and vz < 0.1)):
            if self._landed_candidate_s is None:
                self._landed_candidate_s = nav.time_s
            if nav.time_s - self._landed_candidate_s >= 1.0:
                self.landed_state = _ON_GROUND
                self._ground_since_s = nav.time_s
                self._landed_candidate_s = None
                self._say(SEVERITY_INFO, "Landing detected")
        else:
            self._landed_candidate_s = None

    def _check_preflight_disarm(self, nav: NavInput) -> None:
        since = self._ground_since_s if self._ground_since_s is not None else self._arm_time_s
        since = max(since, self._arm_time_s)
        landed_after_flight = (
            self._ground_since_s is not None and self._ground_since_s >= self._arm_time_s
        )
        limit = self.params.floats()[
            "COM_DISARM_LAND" if landed_after_flight else "COM_DISARM_PRFLT"
        ]
        if limit > 0 and nav.time_s - since >= limit:
            self._disarm("Disarmed by landing" if landed_after_flight else "Disarmed: no takeoff")
