"""Offboard mode: setpoints streamed by a companion computer, and the watchdog on the stream.

PX4's offboard mode flies whatever the last SET_POSITION_TARGET_* / SET_ATTITUDE_TARGET asked,
as long as such messages keep arriving: the mode can only be entered while the stream is fresh
(a setpoint within COM_OF_LOSS_T of simulation time; PX4's guidance is a stream faster than
2 Hz), and a stream that stops for COM_OF_LOSS_T triggers the offboard-loss failsafe
(COM_OBL_RC_ACT). Everything here is pure: setpoints arrive already converted to the local NED
frame (the MAVLink adapter decodes type_mask and frame), and :meth:`OffboardControl.setpoint`
turns the last one into what the position controller or the attitude loop tracks.

Units: SI, NED, radians; NaN marks a component that is not controlled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum, IntEnum

import numpy as np

from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.failsafe import Action
from autopilot_emu.modes.nav_types import NavInput, NavOutput


def _nan3() -> np.ndarray:
    return np.full(3, np.nan)


@dataclass(frozen=True)
class OffboardSetpoint:
    """One offboard setpoint in the local NED frame (NaN or None: not controlled).

    Position, velocity and acceleration are per axis: a finite position is tracked with the
    velocity as feed-forward; an axis with only a velocity is velocity-controlled; an axis with
    only an acceleration is acceleration-controlled. An attitude or body-rate setpoint (with a
    collective thrust) replaces all three.
    """

    position_ned_m: np.ndarray = field(default_factory=_nan3)
    velocity_ned_m_s: np.ndarray = field(default_factory=_nan3)
    acceleration_ned_m_s2: np.ndarray = field(default_factory=_nan3)
    yaw_rad: float = math.nan
    yaw_rate_rad_s: float = math.nan
    attitude_wxyz: np.ndarray | None = None
    """Attitude setpoint, body FRD to NED, [w, x, y, z]."""
    body_rates_rad_s: np.ndarray | None = None
    """Body roll, pitch, yaw rate setpoint (NaN per axis: not controlled)."""
    thrust: float = math.nan
    """Collective thrust 0..1 of an attitude or rate setpoint (NaN: keep the last one)."""

    @property
    def is_attitude(self) -> bool:
        """An attitude or body-rate setpoint (no position loop)."""
        return self.attitude_wxyz is not None or self.body_rates_rad_s is not None

    @property
    def thrust_only(self) -> bool:
        """Only a thrust: it updates the attitude or rate setpoint already flown, as in PX4.

        (SET_ATTITUDE_TARGET that ignores attitude and rates.)
        """
        return (
            not self.is_attitude
            and math.isfinite(self.thrust)
            and not np.isfinite(self.position_ned_m).any()
            and not np.isfinite(self.velocity_ned_m_s).any()
            and not np.isfinite(self.acceleration_ned_m_s2).any()
        )

    @property
    def needs_position(self) -> bool:
        """Flying it needs a local position estimate (PX4's offboard mode requirements)."""
        return not self.is_attitude and (
            bool(np.isfinite(self.position_ned_m).any())
            or bool(np.isfinite(self.velocity_ned_m_s).any())
            or bool(np.isfinite(self.acceleration_ned_m_s2).any())
        )


class LocalFrame(IntEnum):
    """Frames of SET_POSITION_TARGET_LOCAL_NED that PX4 accepts (MAV_FRAME values)."""

    LOCAL_NED = 1
    """Position relative to the local origin; velocity and acceleration in NED."""
    LOCAL_OFFSET_NED = 7
    """Position relative to the vehicle; velocity and acceleration in NED."""
    BODY_NED = 8
    """Everything relative to the vehicle and rotated by its heading (MAVSDK's body velocity)."""
    BODY_OFFSET_NED = 9
    """As BODY_NED."""


def to_local_ned(
    setpoint: OffboardSetpoint, frame: LocalFrame, position_ned_m: np.ndarray, yaw_rad: float
) -> OffboardSetpoint:
    """Express a setpoint given in ``frame`` in the local NED frame, at the vehicle's pose now.

    Body frames are heading-aligned (rotated by yaw only, not by roll and pitch), as PX4
    interprets MAV_FRAME_BODY_NED; their yaw stays absolute. Offsets are added to the current
    position, per axis.
    """
    if frame == LocalFrame.LOCAL_NED:
        return setpoint
    position = setpoint.position_ned_m
    velocity = setpoint.velocity_ned_m_s
    accel = setpoint.acceleration_ned_m_s2
    if frame in (LocalFrame.BODY_NED, LocalFrame.BODY_OFFSET_NED):
        position, velocity, accel = (_rotate_yaw(v, yaw_rad) for v in (position, velocity, accel))
    return OffboardSetpoint(
        position_ned_m=position + position_ned_m,
        velocity_ned_m_s=velocity,
        acceleration_ned_m_s2=accel,
        yaw_rad=setpoint.yaw_rad,
        yaw_rate_rad_s=setpoint.yaw_rate_rad_s,
    )


def _rotate_yaw(v: np.ndarray, yaw_rad: float) -> np.ndarray:
    """Rotate the horizontal part of a heading-frame vector into NED (NaN stays NaN)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    out = v.copy()
    if np.isfinite(v[:2]).all():
        out[0] = c * v[0] - s * v[1]
        out[1] = s * v[0] + c * v[1]
    elif np.isfinite(v[:2]).any():
        out[:2] = np.nan  # one horizontal axis alone has no meaning once rotated
    return out


class AltitudeReference(Enum):
    """What the altitude of a SET_POSITION_TARGET_GLOBAL_INT is measured from."""

    AMSL = "amsl"
    """MAV_FRAME_GLOBAL(_INT): above mean sea level."""
    HOME = "home"
    """MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT): above home."""
    TERRAIN = "terrain"
    """MAV_FRAME_GLOBAL_TERRAIN_ALT(_INT): above the ground; the emulator has no terrain model
    and takes the ground to be level with home."""


GLOBAL_FRAMES = {
    0: AltitudeReference.AMSL,
    5: AltitudeReference.AMSL,
    3: AltitudeReference.HOME,
    6: AltitudeReference.HOME,
    10: AltitudeReference.TERRAIN,
    11: AltitudeReference.TERRAIN,
}
"""MAV_FRAME values accepted by SET_POSITION_TARGET_GLOBAL_INT."""


@dataclass(frozen=True)
class GlobalSetpoint:
    """A geodetic offboard target (SET_POSITION_TARGET_GLOBAL_INT; NaN: ignored axis)."""

    lat_deg: float
    lon_deg: float
    alt_m: float
    reference: AltitudeReference
    setpoint: OffboardSetpoint
    """Velocity, acceleration and yaw parts (NED); its position is unused."""


class LossAction(IntEnum):
    """COM_OBL_RC_ACT values (PX4 failsafe.h offboard_loss_failsafe_mode)."""

    POSITION = 0
    ALTITUDE = 1
    STABILIZED = 2
    RETURN = 3
    LAND = 4
    HOLD = 5
    TERMINATE = 6
    DISARM = 7


def loss_action(com_obl_rc_act: int) -> Action:
    """What the offboard-loss failsafe does, as PX4's mode fallback resolves it without RC.

    Position, Altitude and Stabilized need manual control, which the emulator never has (no RC,
    no MANUAL_CONTROL): PX4's fallback chain then ends in Return (failsafe.cpp,
    checkModeFallback: a mode that cannot run falls back to RTL). Unknown values act as 0.
    """
    try:
        value = LossAction(com_obl_rc_act)
    except ValueError:
        value = LossAction.POSITION
    return {
        LossAction.RETURN: Action.RTL,
        LossAction.LAND: Action.LAND,
        LossAction.HOLD: Action.HOLD,
        LossAction.TERMINATE: Action.TERMINATE,
        LossAction.DISARM: Action.DISARM,
    }.get(value, Action.RTL)


@dataclass
class OffboardTarget:
    """What one tick of offboard mode asks of the controllers (NED, SI)."""

    position_ned_m: np.ndarray
    velocity_ff_m_s: np.ndarray
    acceleration_ff_m_s2: np.ndarray
    yaw_rad: float
    """Heading setpoint; a yaw-rate setpoint is already integrated into it."""
    attitude_wxyz: np.ndarray | None = None
    body_rates_rad_s: np.ndarray | None = None
    thrust: float = math.nan


class OffboardControl:
    """The last offboard setpoint of one vehicle and the freshness of its stream."""

    def __init__(self) -> None:
        self.setpoint: OffboardSetpoint | None = None
        self.received_s = -math.inf
        self._attitude_setpoint: OffboardSetpoint | None = None
        self._thrust = math.nan
        self._yaw_sp = math.nan

    def receive(self, setpoint: OffboardSetpoint, time_s: float) -> bool:
        """Store a setpoint that arrived at simulation time ``time_s``.

        Returns:
            False if it was ignored: a thrust alone while no attitude or rate setpoint is flown.
        """
        if setpoint.thrust_only:
            if self.setpoint is None or not self.setpoint.is_attitude:
                return False
            self._thrust = setpoint.thrust
            self.received_s = time_s
            return True
        if setpoint.is_attitude and math.isfinite(setpoint.thrust):
            self._thrust = setpoint.thrust
        if self.setpoint is None or self.setpoint.is_attitude != setpoint.is_attitude:
            self._yaw_sp = math.nan  # from or to attitude control: start from the heading
        self.setpoint = setpoint
        self.received_s = time_s
        return True

    def fresh(self, time_s: float, timeout_s: float) -> bool:
        """A setpoint arrived within ``timeout_s`` before ``time_s`` (PX4's offboard signal)."""
        return self.setpoint is not None and time_s - self.received_s <= timeout_s

    def target(
        self, position_ned_m: np.ndarray, yaw_rad: float, dt_s: float, hover_thrust: float
    ) -> OffboardTarget:
        """The controller target of this tick (call only when a setpoint exists).

        Without a yaw setpoint the heading is held; a yaw-rate setpoint turns the held heading
        at that rate (integrated here at the navigation rate).
        """
        sp = self.setpoint
        assert sp is not None
        if sp.is_attitude:
            thrust = self._thrust if math.isfinite(self._thrust) else hover_thrust
            return OffboardTarget(
                position_ned_m=_nan3(),
                velocity_ff_m_s=np.zeros(3),
                acceleration_ff_m_s2=_nan3(),
                yaw_rad=yaw_rad,
                attitude_wxyz=sp.attitude_wxyz,
                body_rates_rad_s=sp.body_rates_rad_s,
                thrust=thrust,
            )
        if math.isfinite(sp.yaw_rad):
            self._yaw_sp = sp.yaw_rad
        elif not math.isfinite(self._yaw_sp):
            self._yaw_sp = yaw_rad
        if math.isfinite(sp.yaw_rate_rad_s) and not math.isfinite(sp.yaw_rad):
            self._yaw_sp = _wrap(self._yaw_sp + sp.yaw_rate_rad_s * dt_s)
        position = sp.position_ned_m.copy()
        velocity = sp.velocity_ned_m_s
        accel = sp.acceleration_ned_m_s2
        # An axis with nothing at all is held where it is (PX4 keeps the position there).
        idle = ~(np.isfinite(position) | np.isfinite(velocity) | np.isfinite(accel))
        position[idle] = position_ned_m[idle]
        # NaN velocity on an axis without position: acceleration control on that axis.
        accel_only = ~(np.isfinite(position) | np.isfinite(velocity))
        return OffboardTarget(
            position_ned_m=position,
            velocity_ff_m_s=np.where(accel_only, np.nan, np.nan_to_num(velocity)),
            acceleration_ff_m_s2=np.nan_to_num(accel),
            yaw_rad=self._yaw_sp,
        )

    def output(
        self,
        nav: NavInput,
        out: NavOutput,
        dt_s: float,
        hover_thrust: float,
        params: CommanderParams,
    ) -> None:
        """Write this tick's :meth:`target` into ``out``, with the offboard speed limits.

        The limits are MPC_XY_VEL_MAX, MPC_Z_VEL_MAX_UP / _DN: offboard setpoints are not held
        to the auto modes' speeds.
        """
        target = self.target(nav.position_ned_m, nav.yaw_rad, dt_s, hover_thrust)
        out.position_ned_m = target.position_ned_m
        out.velocity_ff_m_s = target.velocity_ff_m_s
        out.acceleration_ff_m_s2 = target.acceleration_ff_m_s2
        out.yaw_rad = target.yaw_rad
        out.attitude_wxyz = target.attitude_wxyz
        out.body_rates_rad_s = target.body_rates_rad_s
        out.thrust = target.thrust
        out.max_speed_xy_m_s = params.max_speed_xy_m_s
        out.max_speed_up_m_s = params.max_climb_speed_m_s
        out.max_speed_down_m_s = params.max_descent_speed_m_s

    def wants_climb(self, position_ned_m: np.ndarray, hover_thrust: float) -> bool:
        """On the ground: does the setpoint lift the vehicle off (start of a take-off)?"""
        sp = self.setpoint
        if sp is None:
            return False
        if sp.is_attitude:
            thrust = self._thrust if math.isfinite(self._thrust) else 0.0
            return thrust > hover_thrust
        pz, vz, az = sp.position_ned_m[2], sp.velocity_ned_m_s[2], sp.acceleration_ned_m_s2[2]
        if math.isfinite(pz):
            return bool(pz < position_ned_m[2] - 0.3)
        if math.isfinite(vz):
            return bool(vz < -0.1)
        return bool(math.isfinite(az) and az < -0.1)


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
