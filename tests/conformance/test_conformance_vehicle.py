"""MAVSDK conformance: telemetry, param, info, mission, action and flight, both Python APIs.

One ``swarmsitl up`` and one client run per API (``clients/vehicle_conformance.py``): the
classic ``mavsdk_grpc`` API with its ``mavsdk_server`` (port slot 12), then the 4.x native
``mavsdk`` API (slot 13). The client makes each call as a MAVSDK user would and records what it
saw; each test below asserts one capability on that record, for both APIs. Expected values are
what PX4 SITL gives (MAVSDK_CONTRACT.md); rates are measured with the messages' own timestamps.
The plugins swarmsitl does not serve are probed in the classic run only (docs/conformance.md).
"""

from __future__ import annotations

import itertools
import math

import pytest
from conformance_support import Run, run_conformance_client
from e2e_support import module_ports, running_swarm

pytestmark = [pytest.mark.e2e, pytest.mark.conformance]

APIS = ("classic", "native")
"""The client APIs the suite runs (each run on its own block of ports from module_ports)."""
PX4_HOME = (47.397742, 8.545594)
"""PX4 SITL's default home (Zurich), deg."""
TAKEOFF_ALT_M = 5.0
GOTO_SPEED_M_S = 2.0
MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
MAV_CMD_NAV_RALLY_POINT = 5100


@pytest.fixture(scope="module", params=APIS)
def run(request, tmp_path_factory) -> Run:
    """The report of one conformance client run against its own vehicle."""
    api = request.param
    ports = module_ports()
    out = tmp_path_factory.mktemp(f"vehicle-{api}")
    extra = ["--plugins"] if api == "classic" else []
    with running_swarm(1, ports, out / "run") as swarm:
        return run_conformance_client(
            "vehicle_conformance.py", api, ports, out / "clients", extra, swarm.clock,
            timeout_sim_s=1700,
        )  # fmt: skip


def classic_only(run: Run) -> None:
    if run.api != "classic":
        pytest.skip("probed with the classic API only (same C++ core)")


def test_client_run_completes(run):
    """The client finished, and every group it stopped stopped at a failed check (whose test
    fails). Checks a stop left unreached are skipped, pointing here or at that check."""
    problem = run.incomplete()
    assert problem is None, problem


# --- telemetry -------------------------------------------------------------------------------


def test_position_and_home_on_the_ground(run):
    """position() and home() agree on the ground at PX4's SITL home."""
    c = run.check("telemetry_position_home")
    assert c["home"][:2] == pytest.approx(PX4_HOME, abs=1e-4)
    assert c["horizontal_from_home_m"] < 1.0
    assert abs(c["relative_altitude_m"]) < 0.3


def test_states_on_the_ground(run):
    """armed False, in_air False, landed_state ON_GROUND, flight_mode HOLD after boot."""
    c = run.check("telemetry_states_on_ground")
    assert (c["armed"], c["in_air"], c["landed_state"]) == (False, False, "ON_GROUND")
    assert c["flight_mode"] == "HOLD"


def test_attitude_euler_and_quaternion_agree(run):
    """attitude_euler equals attitude_quaternion converted (ZYX), level on the ground."""
    c = run.check("telemetry_attitude")
    assert c["quaternion_norm"] == pytest.approx(1.0, abs=1e-3)
    assert max(abs(d) for d in c["euler_minus_quaternion_deg"]) < 0.5
    roll, pitch, _ = c["euler_deg"]
    assert abs(roll) < 2.0 and abs(pitch) < 2.0


def test_velocity_and_local_position_at_rest(run):
    """velocity_ned and position_velocity_ned: at rest, near the local origin."""
    c = run.check("telemetry_velocity")
    assert math.hypot(*c["velocity_ned_m_s"]) < 0.3
    assert math.hypot(*c["pvn_velocity_m_s"]) < 0.3
    assert math.hypot(*c["position_ned_m"][:2]) < 1.0


def test_battery_gps_and_raw_gps(run):
    """battery (full 4S), gps_info (3D fix), raw_gps (timestamped, at the position)."""
    c = run.check("telemetry_battery_gps")
    assert 14.0 < c["battery_voltage_v"] < 17.5
    assert 90.0 <= c["battery_remaining_percent"] <= 100.0
    assert c["gps_fix_type"] == "FIX_3D"
    assert c["gps_satellites"] >= 6
    assert c["raw_gps_timestamp_us"] > 0
    assert c["raw_gps_from_position_m"] < 2.0


def test_health_and_unix_epoch_time(run):
    """health() all true (armable), health_all_ok() true, unix_epoch_time() a plausible date."""
    c = run.check("telemetry_health_time")
    assert all(c["health"].values()), c["health"]
    assert c["health_all_ok"] is True
    assert c["unix_epoch_time_us"] > 1_577_836_800_000_000  # after 2020-01-01


def test_default_rates_in_simulation_time(run):
    """Unprompted rates of PX4's onboard profile, the one MAVSDK's port gets (ATTITUDE 100 Hz,
    ATTITUDE_QUATERNION 50 Hz, GPS_RAW_INT at every GPS fix: 10 Hz here); SYSTEM_TIME every 1 s.
    """
    c = run.check("rates_default")
    assert c["attitude_euler_hz"] == pytest.approx(100.0, rel=0.05)
    assert c["attitude_quaternion_hz"] == pytest.approx(50.0, rel=0.05)
    assert c["raw_gps_hz"] == pytest.approx(10.0, rel=0.1)
    assert c["unix_epoch_steps_s"] == pytest.approx([1.0] * 3, abs=0.01)


def test_set_rate_is_honoured(run):
    """set_rate_attitude_euler(5) and set_rate_raw_gps(2) give those rates (simulation time)."""
    c = run.check("rates_set")
    assert c["attitude_euler_hz"] == pytest.approx(5.0, rel=0.05)
    assert c["raw_gps_hz"] == pytest.approx(2.0, rel=0.05)


# --- param -----------------------------------------------------------------------------------


def test_param_float_get_set(run):
    """MIS_TAKEOFF_ALT: PX4 default 2.5, set 7.5 reads back."""
    c = run.check("param_float")
    assert c["default"] == pytest.approx(2.5)
    assert c["after_set"] == pytest.approx(7.5)


def test_param_int_get_set_restore(run):
    """NAV_RCL_ACT: PX4 default 2, set 3 reads back, restore."""
    c = run.check("param_int")
    assert (c["default"], c["after_set"], c["restored"]) == (2, 3, 2)


def test_get_all_params(run):
    """get_all_params: ints and floats apart, each name once, values as get_param gives them."""
    c = run.check("param_all")
    assert c["int_count"] >= 5 and c["float_count"] >= 20
    assert c["names_in_both"] == []
    assert c["NAV_RCL_ACT"] == 2
    assert c["MIS_TAKEOFF_ALT"] == pytest.approx(7.5)
    assert c["SYS_AUTOSTART"] is not None


def test_param_errors(run):
    """Wrong type, unknown name, too long, out of range: each its MAVSDK error; value kept."""
    c = run.check("param_errors")
    assert c["get_int_of_float"] == "WRONG_TYPE"
    assert c["get_float_of_int"] == "WRONG_TYPE"
    assert c["set_int_on_float"] == "TYPE_MISMATCH"
    assert c["set_float_on_int"] == "TYPE_MISMATCH"
    assert c["get_unknown"] == "DOES_NOT_EXIST"
    assert c["set_unknown"] == "DOES_NOT_EXIST"
    assert c["name_too_long"] == "PARAM_NAME_TOO_LONG"
    assert c["set_out_of_range"] == "VALUE_OUT_OF_RANGE"
    assert c["value_after_refusals"] == c["value_before_refusals"]


# --- info ------------------------------------------------------------------------------------


def test_info_version_identification_product(run):
    """get_version (PX4 1.x release), get_identification (a uid), get_product answer."""
    c = run.check("info_version_identification_product")
    assert c["flight_sw"][0] == 1
    assert c["flight_sw_version_type"] == "RELEASE"
    assert c["legacy_uid"] != 0
    assert len(c["product"]) == 3


def test_info_flight_information_streams(run):
    """flight_information(): MAVSDK asks for 1 Hz; time_boot_ms advances 1 s per item."""
    times = run.check("info_flight_information")["time_boot_ms"]
    steps = [b - a for a, b in itertools.pairwise(times)]
    assert steps == pytest.approx([1000, 1000], abs=20)


# --- mission, on the ground --------------------------------------------------------------------


def test_start_mission_without_mission_is_refused(run):
    """start_mission with nothing uploaded is refused by the vehicle (not a timeout)."""
    assert run.check("mission_start_without_mission")["start_mission"] not in (
        "SUCCESS",
        "TIMEOUT",
        "NO_ANSWER",
    )


def test_set_current_mission_item(run):
    """set_current_mission_item(2): progress reports 2 of 3; not finished; 9 is invalid; clear."""
    c = run.check("mission_set_current_item")
    assert [2, 3] in c["progress"]
    assert c["is_mission_finished"] is False
    assert c["set_current_out_of_range"] == "INVALID_ARGUMENT"
    assert c["items_after_clear"] == 0


def test_qgroundcontrol_plan_import_round_trip(run):
    """A QGC .plan imported by mission_raw uploads as mission, fence and rally and reads back."""
    c = run.check("mission_raw_qgc_import")
    assert c["downloaded"] == c["imported"]
    assert c["imported"][1] == [MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION] * 4
    assert c["imported"][2] == [MAV_CMD_NAV_RALLY_POINT]
    assert c["after_clear"] == [0, 0]


# --- action ----------------------------------------------------------------------------------


def test_takeoff_while_disarmed_is_denied(run):
    assert run.check("action_takeoff_refused_disarmed")["takeoff_disarmed"] == "COMMAND_DENIED"


def test_takeoff_and_rtl_altitude_setters(run):
    """set/get_takeoff_altitude and set/get_return_to_launch_altitude round trip."""
    c = run.check("action_takeoff_rtl_altitudes")
    assert c["takeoff_altitude_m"] == pytest.approx(TAKEOFF_ALT_M)
    assert c["rtl_altitude_m"] == pytest.approx(8.0)


def test_arm_disarm_kill_and_reboot_while_armed(run):
    """arm/disarm/kill on the ground change armed(); reboot while armed is denied (as PX4)."""
    c = run.check("action_arm_disarm_kill")
    assert c["reboot_while_armed"] == "COMMAND_DENIED"
    assert c["kill_text"] is True


def test_reboot_and_shutdown_are_acknowledged_and_ignored(run):
    """reboot()/shutdown() disarmed succeed as on PX4; the simulated vehicle keeps running."""
    c = run.check("action_reboot_shutdown")
    assert (c["reboot"], c["shutdown"]) == ("SUCCESS", "SUCCESS")
    assert c["still_streaming"] is True
    assert c["ignored_text"] is True


def test_calls_swarmsitl_does_not_serve_are_refused_at_once(run):
    """do_orbit, set_actuator, set_relay: UNSUPPORTED (not a timeout); no VTOL transitions."""
    c = run.check("action_not_served")
    assert c["do_orbit"] == "UNSUPPORTED"
    assert c["set_actuator"] == "UNSUPPORTED"
    assert c["set_relay"] == "UNSUPPORTED"
    assert c["transition_to_fixedwing"] == "NO_VTOL_TRANSITION_SUPPORT"


def test_takeoff_climbs_to_the_takeoff_altitude_then_holds(run):
    """takeoff(): TAKEOFF then HOLD at 5 m (+-0.3 m); landed_state ON_GROUND -> IN_AIR."""
    c = run.check("flight_takeoff")
    assert c["rel_alt_max_error_m"] < 0.3
    assert (c["in_air"], c["landed_state"], c["flight_mode"]) == (True, "IN_AIR", "HOLD")
    assert c["modes"][-2:] == ["TAKEOFF", "HOLD"]
    assert c["landed_states"][-1] == "IN_AIR"


def test_disarm_in_the_air_is_denied(run):
    c = run.check("flight_disarm_refused_in_air")
    assert c["disarm"] == "COMMAND_DENIED"
    assert c["armed_after"] is True


def test_goto_location_flies_at_the_set_current_speed(run):
    """set_current_speed(2) then goto_location 20 m north: arrives, cruising at 2 m/s, nose down."""
    c = run.check("flight_goto_at_set_speed")
    assert c["distance_m"] < 1.0
    assert c["local_north_travelled_m"] == pytest.approx(20.0, abs=1.0)
    assert c["max_ground_speed_m_s"] == pytest.approx(GOTO_SPEED_M_S, rel=0.1)
    assert c["min_pitch_deg"] < -1.0
    assert c["flight_mode"] == "HOLD"


def test_hold_stops_the_vehicle(run):
    """hold() during a goto at ~4 m/s: HOLD, at rest within braking distance, target abandoned."""
    c = run.check("flight_hold")
    assert c["speed_at_hold_m_s"] > 2.0
    assert c["flight_mode"] == "HOLD"
    assert c["ground_speed_m_s"] < 0.3
    assert c["distance_to_goto_target_m"] > 10.0
    # PX4's Loiter braking point (calculate_breaking_stop): v²/(2 MPC_ACC_HOR) plus 0.6 s of
    # travel while the jerk-limited deceleration builds up (MPC_ACC_HOR = 3 m/s²). The emulator
    # holds up to ~0.7 m further, where its smoothed setpoint stops without turning back, and
    # the client measures from a position it read before the call (the call's own travel).
    speed = c["speed_at_hold_m_s"]
    braking_m = speed**2 / (2 * 3.0) + 0.6 * speed
    assert abs(c["along_track_final_m"]) < braking_m + 2.0


def test_hold_brakes_to_a_stop_without_coming_back(run):
    """Past its furthest point, the vehicle settles back by tracking error only (< 0.4 m)."""
    c = run.check("flight_hold")
    assert c["overshoot_max_m"] - c["along_track_final_m"] < 0.4


def test_return_to_launch_lands_at_home_and_disarms(run):
    """return_to_launch(): RETURN_TO_LAUNCH, LANDING, lands within 1.5 m of home, disarms."""
    c = run.check("flight_return_to_launch")
    assert c["modes"][-1] == "RETURN_TO_LAUNCH"
    assert c["landed_states"][-2:] == ["LANDING", "ON_GROUND"]
    assert c["horizontal_from_home_m"] < 1.5
    assert abs(c["rel_alt_m"]) < 0.5


def test_land_lands_and_disarms(run):
    c = run.check("flight_land")
    assert c["mode"] == "LAND"
    assert abs(c["rel_alt_m"]) < 0.5


def test_set_home(run):
    """set_home(10 m north): home() reports the new home."""
    c = run.check("action_set_home")
    assert c["home_north_m"] == pytest.approx(10.0, abs=0.1)
    assert abs(c["home_east_m"]) < 0.1


def test_terminate_disarms(run):
    assert run.check("action_terminate_on_ground")["text"] is True


# --- other plugins (classic run) ------------------------------------------------------------------


def test_failure_injection_gps(run):
    """failure.inject(GPS, OFF) with SYS_FAILURE_EN 1: global position lost; OK brings it back."""
    classic_only(run)
    c = run.check("failure_inject_gps")
    assert c["enabled"] == 1
    assert c["gps_off"] == "SUCCESS"
    assert c["lost_text"] is True
    assert c["gyro_off"] == "UNSUPPORTED"
    assert c["gps_ok"] == "SUCCESS"
    assert c["fix_after_ok"] == "FIX_3D"


NOT_SERVED = {
    "manual_control_without_input": "INPUT_NOT_SET",  # client-side, before any MAVLink
    "manual_control_position": "COMMAND_DENIED",  # no manual modes without RC
    "tune_play": "SUCCESS",  # PLAY_TUNE_V2 is fire-and-forget; the vehicle ignores it
    "calibration_gyro": "UNSUPPORTED",
    "gimbal_take_control": "ERROR",  # no gimbal manager
    "follow_me_start": "COMMAND_DENIED",  # AUTO/FOLLOW_TARGET refused
    "winch_relax": "TIMEOUT",  # no winch component answers
    "gripper_release": "UNSUPPORTED",
    "log_files_entries": "TIMEOUT",  # no log protocol
    "shell_send": "SUCCESS",  # SERIAL_CONTROL goes out ...
    "shell_receive": "NO_ANSWER",  # ... and nothing comes back
    "transponder": "NO_ANSWER",  # no ADSB_VEHICLE
    "component_metadata": "NOT_REQUESTED",
    "param_custom": "TIMEOUT",  # no PARAM_EXT protocol
}
"""What each plugin swarmsitl does not serve answers (docs/conformance.md)."""


def test_plugins_not_served_fail_cleanly(run):
    """Each probe ends with the documented result; the camera list is empty."""
    classic_only(run)
    c = run.check("plugins_not_served")
    assert {k: c[k] for k in NOT_SERVED} == NOT_SERVED
    assert c["camera_count"] == 0
