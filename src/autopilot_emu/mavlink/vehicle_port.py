"""What the MAVLink endpoint needs from one emulated vehicle.

The endpoint (``autopilot_emu.mavlink.endpoint``) speaks the wire protocol; the commander and
estimator behind this interface decide what happens. Keeping the two apart lets the endpoint be
tested against a fake vehicle and lets the flight stack run without sockets (lockstep benchmarks).

Units: SI, angles in radians unless the name says ``_deg``; NED frame; altitudes AMSL unless the
name says ``relative``. Snapshots are plain slotted dataclasses, built once per poll and never
changed afterwards; they are not frozen because a frozen dataclass of this size costs four times
as much to build, on the telemetry hot path (hundreds of snapshots per simulated second).
Results are ``MAV_RESULT`` integers (0 accepted, 1 temporarily rejected, 2 denied, 3 unsupported,
4 failed).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from autopilot_emu.mission.camera_items import ComponentCommand
from autopilot_emu.mission.items import MissionItem, MissionType
from autopilot_emu.modes.offboard import GlobalSetpoint, LocalFrame, OffboardSetpoint
from autopilot_emu.params import ParamStore
from autopilot_emu.rangefinder import RangeReading


@dataclass(slots=True)
class HomeSnapshot:
    """Home position as HOME_POSITION reports it."""

    lat_deg: float
    """Latitude, degrees."""
    lon_deg: float
    """Longitude, degrees."""
    alt_amsl_m: float
    """Altitude above mean sea level, m."""
    local_ned_m: tuple[float, float, float]
    """Home in the local NED frame of LOCAL_POSITION_NED, m."""


@dataclass(slots=True)
class SetpointSnapshot:
    """What the controllers track now; NaN marks what is not controlled.

    PX4's vehicle_local_position_setpoint, vehicle_attitude_setpoint, vehicle_rates_setpoint.
    """

    position_ned_m: tuple[float, float, float]
    """Position setpoint in the local NED frame, m; NaN on an axis that is velocity-controlled."""
    velocity_ned_m_s: tuple[float, float, float]
    """Velocity setpoint, m/s (the position loop's output plus feed-forward)."""
    acceleration_ned_m_s2: tuple[float, float, float]
    """Acceleration setpoint, m/s²; NaN where the controller has none."""
    yaw_rad: float
    """Heading setpoint, rad; NaN = not controlled."""
    yaw_rate_rad_s: float
    """Yaw-rate setpoint, rad/s; NaN = not controlled."""
    global_position: tuple[float, float, float]
    """The position setpoint as latitude, longitude (deg) and AMSL altitude (m); NaN where the
    local setpoint is NaN or the vehicle has no EKF origin."""
    attitude_wxyz: tuple[float, float, float, float]
    """Attitude setpoint quaternion, body FRD to NED."""
    body_rates_rad_s: tuple[float, float, float]
    """Body-rate setpoint (roll, pitch, yaw), rad/s."""
    thrust: float
    """Collective thrust setpoint, 0..1."""


@dataclass(slots=True)
class ImuSample:
    """The last IMU sample the flight stack received (HIGHRES_IMU), body FRD."""

    time_usec: int
    """Sample time since boot, microseconds."""
    accel_m_s2: tuple[float, float, float]
    gyro_rad_s: tuple[float, float, float]
    mag_gauss: tuple[float, float, float]
    abs_pressure_hpa: float
    diff_pressure_hpa: float
    pressure_alt_m: float
    temperature_degc: float
    fields_updated: int
    """HIGHRES_IMU_UPDATED_FLAGS of the fields that are new in this sample."""


@dataclass(slots=True)
class EstimatorSnapshot:
    """Estimator health and uncertainty (ESTIMATOR_STATUS, ODOMETRY covariances)."""

    flags: int
    """ESTIMATOR_STATUS_FLAGS of the solution's valid parts."""
    pos_horiz_accuracy_m: float
    """1-sigma horizontal position uncertainty, m."""
    pos_vert_accuracy_m: float
    """1-sigma vertical position uncertainty, m."""
    position_variance_m2: tuple[float, float, float]
    """Variance of the NED position estimate, m²."""
    velocity_variance_m2_s2: tuple[float, float, float]
    """Variance of the NED velocity estimate, m²/s²."""
    origin_lla: tuple[float, float, float] | None
    """EKF origin (GPS_GLOBAL_ORIGIN): latitude, longitude (deg), AMSL altitude (m); None
    until the first good fix."""
    origin_time_usec: int
    """When the origin was set, microseconds since boot (0: not set)."""
    vel_ratio: float = 0.0
    """Velocity innovation test ratio, sqrt(innov² / (gate² S)): above 1 the sample is rejected."""
    pos_horiz_ratio: float = 0.0
    """Horizontal position innovation test ratio."""
    pos_vert_ratio: float = 0.0
    """Vertical position (height) innovation test ratio."""
    mag_ratio: float = 0.0
    """Magnetic heading innovation test ratio."""


@dataclass(slots=True)
class TelemetrySnapshot:
    """Everything the telemetry streams report, read at one instant of simulation time."""

    time_usec: int
    """Simulation time since boot, microseconds (source of time_boot_ms / time_usec fields)."""
    armed: bool
    main_mode: int
    """PX4 main mode (1 MANUAL ... 4 AUTO, 6 OFFBOARD)."""
    sub_mode: int
    """PX4 AUTO sub mode (1 READY, 2 TAKEOFF, 3 LOITER, 4 MISSION, 5 RTL, 6 LAND), else 0."""
    landed_state: int
    """MAV_LANDED_STATE: 1 on ground, 2 in air, 3 taking off, 4 landing."""
    system_status: int
    """MAV_STATE: 3 standby, 4 active, 5 critical."""
    sensors_present: int
    """MAV_SYS_STATUS_SENSOR bitmask of fitted sensors (also used as 'enabled')."""
    sensors_health: int
    """MAV_SYS_STATUS_SENSOR bitmask of healthy sensors, incl. PREARM_CHECK when armable."""
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    relative_alt_m: float
    """Altitude above home, m."""
    position_ned_m: tuple[float, float, float]
    """Estimated position in the local NED frame (origin = EKF origin), m."""
    velocity_ned_m_s: tuple[float, float, float]
    quaternion_wxyz: tuple[float, float, float, float]
    """Estimated attitude, body FRD to NED."""
    euler_rad: tuple[float, float, float]
    """Roll, pitch, yaw (ZYX), rad."""
    body_rates_rad_s: tuple[float, float, float]
    throttle: float
    """Collective thrust command, 0..1."""
    gps_fix_type: int
    """GPS_FIX_TYPE (0 none, 3 3D fix)."""
    gps_lat_deg: float
    gps_lon_deg: float
    gps_alt_amsl_m: float
    gps_eph_m: float
    gps_epv_m: float
    gps_satellites: int
    gps_velocity_ned_m_s: tuple[float, float, float]
    battery_voltage_v: float
    battery_current_a: float
    """Negative or NaN when unknown."""
    battery_remaining_pct: int
    """0..100, -1 unknown."""
    battery_consumed_mah: float
    home: HomeSnapshot | None
    """None until the vehicle has a home (before the first good position estimate)."""
    takeoff_alt_amsl_m: float = float("nan")
    setpoint: SetpointSnapshot | None = None
    """None while no controller runs (disarmed, or idle on the ground)."""
    imu: ImuSample | None = None
    """None before the first IMU sample."""
    estimator: EstimatorSnapshot | None = None
    """None if the flight stack does not report it."""
    extra: dict[str, float] = field(default_factory=dict)
    """Free-form extras for optional streams (``bottom_clearance_m``: height above the terrain,
    ``altitude_terrain_m``: terrain altitude AMSL, when the terrain estimate is valid)."""
    distance_sensors: tuple[RangeReading, ...] = ()
    """Latest reading of each distance sensor, by id (DISTANCE_SENSOR stream)."""


class VehiclePort(Protocol):
    """The commander-side API the MAVLink endpoint calls. Every call is made from the sim loop."""

    params: ParamStore
    """This vehicle's PX4 parameters."""

    def telemetry(self) -> TelemetrySnapshot:
        """Current state for the telemetry streams."""
        ...

    def arm(self, force: bool) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM param1=1. Denied while not armable unless forced."""
        ...

    def disarm(self, force: bool) -> int:
        """param1=0. Denied in the air unless forced (param2=21196: kill, motors stop at once)."""
        ...

    def takeoff(self, alt_amsl_m: float | None) -> int:
        """MAV_CMD_NAV_TAKEOFF; None (param7 NaN) climbs to home + MIS_TAKEOFF_ALT."""
        ...

    def land(self) -> int:
        """MAV_CMD_NAV_LAND at the current position."""
        ...

    def set_mode(self, main_mode: int, sub_mode: int) -> int:
        """MAV_CMD_DO_SET_MODE with PX4 custom main/sub modes (param1's armed bit is ignored)."""
        ...

    def reposition(
        self, lat_deg: float, lon_deg: float, alt_amsl_m: float, yaw_rad: float, speed_m_s: float
    ) -> int:
        """MAV_CMD_DO_REPOSITION; NaN for any argument keeps the current value."""
        ...

    def change_speed(self, speed_m_s: float) -> int:
        """MAV_CMD_DO_CHANGE_SPEED (ground speed, m/s; -1 or NaN = default)."""
        ...

    def set_home(self, use_current: bool, lat_deg: float, lon_deg: float, alt_amsl_m: float) -> int:
        """MAV_CMD_DO_SET_HOME."""
        ...

    def terminate(self) -> int:
        """MAV_CMD_DO_FLIGHTTERMINATION: motors off at once."""
        ...

    def pop_status_texts(self) -> list[tuple[int, str]]:
        """(MAV_SEVERITY, text) events raised since the last call, for STATUSTEXT."""
        ...

    def mission_items(self, kind: MissionType) -> tuple[MissionItem, ...]:
        """The stored mission, geofence or rally plan."""
        ...

    def upload_mission(self, kind: MissionType, items: tuple[MissionItem, ...]) -> int:
        """Replace a plan (empty: clear it); return the MAV_MISSION_RESULT for MISSION_ACK."""
        ...

    def set_mission_current(self, seq: int) -> bool:
        """MISSION_SET_CURRENT; False if ``seq`` is not an item of the mission."""
        ...

    def mission_status(self) -> tuple[int, int, int]:
        """(current seq, total, MISSION_STATE) for MISSION_CURRENT; cheap, read every poll."""
        ...

    def pop_mission_reached(self) -> list[int]:
        """Mission items completed since the last call, for MISSION_ITEM_REACHED."""
        ...

    def pop_component_commands(self) -> list[ComponentCommand]:
        """Commands for the vehicle's other components since the last call.

        Every link sends each as COMMAND_LONG from the autopilot (a mission's camera items).
        """
        ...

    def gcs_heartbeat(self) -> None:
        """A HEARTBEAT of a ground station arrived (data-link-loss failsafe)."""
        ...

    def start_mission(self, first_seq: int) -> int:
        """MAV_CMD_MISSION_START: arm and fly the mission from ``first_seq`` (-1: current)."""
        ...

    def inject_failure(self, unit: int, failure_type: int, instance: int) -> int:
        """MAV_CMD_INJECT_FAILURE; MAV_RESULT (DENIED unless SYS_FAILURE_EN is 1)."""
        ...

    def offboard_setpoint(self, setpoint: OffboardSetpoint, frame: LocalFrame) -> bool:
        """SET_POSITION_TARGET_LOCAL_NED or SET_ATTITUDE_TARGET, decoded; False if ignored."""
        ...

    def offboard_setpoint_global(self, target: GlobalSetpoint) -> bool:
        """SET_POSITION_TARGET_GLOBAL_INT, decoded; False if ignored (no origin or home yet)."""
        ...

    def vision_measurement(
        self,
        time_usec: int,
        position_ned_m: np.ndarray,
        position_var_m2: np.ndarray,
        yaw_rad: float,
        yaw_var_rad2: float,
        velocity_ned_m_s: np.ndarray | None,
    ) -> None:
        """External vision (VISION_POSITION_ESTIMATE / ODOMETRY), decoded to the local NED frame.

        ``time_usec`` is the sample's time on this vehicle's clock (since boot); variances are
        m² / rad², NaN where unknown; ``yaw_rad`` NaN without a heading; velocity None if absent.
        """
        ...
