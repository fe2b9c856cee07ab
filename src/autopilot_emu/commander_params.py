"""The parameters the commander, the flight modes and the failsafes read, of one vehicle.

Names and meanings are PX4's (commander, navigator, mc_pos_control, battery, geofence); every
value used in those modules is here once, in SI units, so they never index the store by name.
The commander builds one per vehicle with :meth:`CommanderParams.from_params` and rebuilds it
when its store's :attr:`~autopilot_emu.params.ParamStore.version` changes, so a PARAM_SET takes
effect at the next read, as before.
"""

from __future__ import annotations

from dataclasses import dataclass

from autopilot_emu.params import ParamStore


@dataclass(frozen=True, slots=True)
class CommanderParams:
    """Commander, navigator and failsafe parameters of one vehicle, SI units."""

    hover_thrust: float
    """MPC_THR_HOVER: hover thrust used until the estimator has learned it, 0..1."""
    cruise_speed_m_s: float
    """MPC_XY_CRUISE: horizontal speed of the auto modes, m/s."""
    max_speed_xy_m_s: float
    """MPC_XY_VEL_MAX: largest horizontal speed (auto modes and offboard), m/s."""
    auto_climb_speed_m_s: float
    """MPC_Z_V_AUTO_UP: climb speed of the auto modes, m/s."""
    auto_descent_speed_m_s: float
    """MPC_Z_V_AUTO_DN: descent speed of the auto modes (and of Land high up), m/s."""
    max_climb_speed_m_s: float
    """MPC_Z_VEL_MAX_UP: largest climb speed (offboard), m/s."""
    max_descent_speed_m_s: float
    """MPC_Z_VEL_MAX_DN: largest descent speed (offboard), m/s."""
    land_speed_m_s: float
    """MPC_LAND_SPEED: descent speed of Land near the ground, m/s."""
    acc_hor_m_s2: float
    """MPC_ACC_HOR: horizontal acceleration of the auto modes (Hold's braking), m/s²."""
    jerk_auto_m_s3: float
    """MPC_JERK_AUTO: jerk limit of the auto modes (Hold's braking), m/s³."""
    takeoff_speed_m_s: float
    """MPC_TKO_SPEED: climb speed of a take-off, m/s."""
    takeoff_ramp_s: float
    """MPC_TKO_RAMP_T: time of the take-off's climb-rate ramp, s."""
    z_vel_p_acc_1_s: float
    """MPC_Z_VEL_P_ACC: vertical velocity error to acceleration gain, 1/s."""
    takeoff_alt_m: float
    """MIS_TAKEOFF_ALT: default take-off height above home, m."""
    rtl_return_alt_m: float
    """RTL_RETURN_ALT: return altitude above home, m."""
    acceptance_radius_m: float
    """NAV_ACC_RAD: horizontal acceptance radius of waypoints, m."""
    altitude_radius_m: float
    """NAV_MC_ALT_RAD: vertical acceptance radius of mission items, m."""
    dist_1wp_m: float
    """MIS_DIST_1WP: largest distance from home to the first waypoint (0: off), m."""
    fence_max_hor_dist_m: float
    """GF_MAX_HOR_DIST: largest horizontal distance from home (0: off), m."""
    fence_max_ver_dist_m: float
    """GF_MAX_VER_DIST: largest height above home (0: off), m."""
    fence_action: int
    """GF_ACTION: geofence breach action (failsafe.GF_ACTIONS)."""
    offboard_loss_timeout_s: float
    """COM_OF_LOSS_T: offboard setpoints older than this are lost, s."""
    offboard_loss_action: int
    """COM_OBL_RC_ACT: offboard-loss action (modes.offboard.loss_action)."""
    datalink_loss_timeout_s: float
    """COM_DL_LOSS_T: time without a GCS HEARTBEAT before data-link loss, s."""
    datalink_loss_action: int
    """NAV_DLL_ACT: data-link-loss action (failsafe.DLL_ACTIONS)."""
    battery_low: float
    """BAT_LOW_THR: state of charge at which the battery is low, 0..1."""
    battery_critical: float
    """BAT_CRIT_THR: state of charge at which the battery is critical, 0..1."""
    battery_emergency: float
    """BAT_EMERGEN_THR: state of charge at which the battery is an emergency, 0..1."""
    low_battery_action: int
    """COM_LOW_BAT_ACT: battery failsafe action (failsafe.battery_action)."""
    disarm_land_s: float
    """COM_DISARM_LAND: auto-disarm this long after landing (0: off), s."""
    disarm_preflight_s: float
    """COM_DISARM_PRFLT: auto-disarm this long after arming without a take-off (0: off), s."""

    @classmethod
    def from_params(cls, store: ParamStore) -> CommanderParams:
        """Read the current values of one vehicle's store."""
        f = store.floats()
        get = store.get
        return cls(
            hover_thrust=f["MPC_THR_HOVER"],
            cruise_speed_m_s=f["MPC_XY_CRUISE"],
            max_speed_xy_m_s=f["MPC_XY_VEL_MAX"],
            auto_climb_speed_m_s=f["MPC_Z_V_AUTO_UP"],
            auto_descent_speed_m_s=f["MPC_Z_V_AUTO_DN"],
            max_climb_speed_m_s=f["MPC_Z_VEL_MAX_UP"],
            max_descent_speed_m_s=f["MPC_Z_VEL_MAX_DN"],
            land_speed_m_s=f["MPC_LAND_SPEED"],
            acc_hor_m_s2=f["MPC_ACC_HOR"],
            jerk_auto_m_s3=f["MPC_JERK_AUTO"],
            takeoff_speed_m_s=f["MPC_TKO_SPEED"],
            takeoff_ramp_s=f["MPC_TKO_RAMP_T"],
            z_vel_p_acc_1_s=f["MPC_Z_VEL_P_ACC"],
            takeoff_alt_m=f["MIS_TAKEOFF_ALT"],
            rtl_return_alt_m=f["RTL_RETURN_ALT"],
            acceptance_radius_m=f["NAV_ACC_RAD"],
            altitude_radius_m=f["NAV_MC_ALT_RAD"],
            dist_1wp_m=f["MIS_DIST_1WP"],
            fence_max_hor_dist_m=f["GF_MAX_HOR_DIST"],
            fence_max_ver_dist_m=f["GF_MAX_VER_DIST"],
            fence_action=int(get("GF_ACTION")),
            offboard_loss_timeout_s=f["COM_OF_LOSS_T"],
            offboard_loss_action=int(get("COM_OBL_RC_ACT")),
            datalink_loss_timeout_s=f["COM_DL_LOSS_T"],
            datalink_loss_action=int(get("NAV_DLL_ACT")),
            battery_low=f["BAT_LOW_THR"],
            battery_critical=f["BAT_CRIT_THR"],
            battery_emergency=f["BAT_EMERGEN_THR"],
            low_battery_action=int(get("COM_LOW_BAT_ACT")),
            disarm_land_s=f["COM_DISARM_LAND"],
            disarm_preflight_s=f["COM_DISARM_PRFLT"],
        )
