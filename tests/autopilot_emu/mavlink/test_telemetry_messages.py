"""Snapshot -> MAVLink field conversions (units, unknown markers, PX4 encodings)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from mavlink_fakes import EPOCH_START_S, make_snapshot
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink import messages
from autopilot_emu.params import ParamStore

CONTEXT = messages.MessageContext(
    sysid=3, params=ParamStore(), epoch_start_us=round(EPOCH_START_S * 1e6)
)


def _packs(message):
    """The message must survive pymavlink packing (ranges and types)."""
    message.pack(mavlink2.MAVLink(None, 1, 1))
    return message


@pytest.mark.parametrize(
    ("main", "sub", "expected"),
    [(1, 0, 65536), (3, 0, 196608), (4, 2, 33816576), (4, 5, 84148224), (6, 0, 393216)],
)
def test_custom_mode_matches_the_px4_table(main, sub, expected):
    assert messages.custom_mode(main, sub) == expected


def test_base_mode_flags():
    assert messages.base_mode(False, 4) == 1 | 4 | 8 | 16
    assert messages.base_mode(True, 3) == 1 | 8 | 16 | 64 | 128
    assert messages.base_mode(False, 42) == 1


def test_global_position_int_units():
    snapshot = make_snapshot(
        time_usec=12_345_678,
        lat_deg=47.3977421,
        lon_deg=8.5455941,
        alt_amsl_m=498.25,
        relative_alt_m=10.25,
        velocity_ned_m_s=(1.5, -0.25, -2.0),
        euler_rad=(0.0, 0.0, -math.pi / 2),
    )
    msg = _packs(messages.global_position_int(snapshot, CONTEXT))
    assert msg.time_boot_ms == 12_345
    assert (msg.lat, msg.lon) == (473977421, 85455941)
    assert (msg.alt, msg.relative_alt) == (498250, 10250)
    assert (msg.vx, msg.vy, msg.vz) == (150, -25, -200)
    assert msg.hdg == 27000


def test_heading_unknown_is_65535_and_huge_speeds_clamp():
    snapshot = make_snapshot(euler_rad=(0.0, 0.0, math.nan), velocity_ned_m_s=(1e6, 0.0, 0.0))
    msg = _packs(messages.global_position_int(snapshot, CONTEXT))
    assert msg.hdg == 65535
    assert msg.vx == 32767


def test_gps_raw_int_fields():
    snapshot = make_snapshot(gps_velocity_ned_m_s=(0.0, 2.0, 0.0), gps_eph_m=0.9, gps_epv_m=1.4)
    msg = _packs(messages.gps_raw_int(snapshot, CONTEXT))
    assert msg.fix_type == 3 and msg.satellites_visible == 12
    assert msg.vel == 200 and msg.cog == 9000
    assert (msg.h_acc, msg.v_acc) == (900, 1400)
    assert msg.eph == 65535  # HDOP unknown unless the vehicle provides extra["gps_hdop"]
    snapshot = replace(snapshot, extra={"gps_hdop": 0.7})
    assert messages.gps_raw_int(snapshot, CONTEXT).eph == 70


def test_sys_status_and_battery_status():
    snapshot = make_snapshot(battery_voltage_v=16.4, battery_current_a=12.3)
    status = _packs(messages.sys_status(snapshot, CONTEXT))
    assert status.onboard_control_sensors_health & 0x10000000
    assert (status.voltage_battery, status.current_battery, status.battery_remaining) == (
        16400,
        1230,
        95,
    )
    battery = _packs(messages.battery_status(snapshot, CONTEXT))
    assert battery.voltages[:4] == [4100] * 4
    assert battery.voltages[4:] == [65535] * 6
    assert battery.charge_state == mavlink2.MAV_BATTERY_CHARGE_STATE_OK
    assert battery.current_consumed == 12


def test_battery_unknown_values_and_low_charge():
    snapshot = make_snapshot(
        battery_voltage_v=math.nan,
        battery_current_a=math.nan,
        battery_remaining_pct=6,
        battery_consumed_mah=math.nan,
    )
    status = _packs(messages.sys_status(snapshot, CONTEXT))
    assert (status.voltage_battery, status.current_battery) == (65535, -1)
    battery = _packs(messages.battery_status(snapshot, CONTEXT))
    assert battery.current_battery == -1 and battery.current_consumed == -1
    assert battery.charge_state == mavlink2.MAV_BATTERY_CHARGE_STATE_CRITICAL


def test_home_position_and_system_time():
    snapshot = make_snapshot(time_usec=2_500_000)
    home = _packs(messages.home_position(snapshot, CONTEXT))
    assert home.altitude == 488000
    assert home.time_usec == 2_500_000
    assert messages.home_position(replace(snapshot, home=None), CONTEXT) is None
    time_msg = _packs(messages.system_time(snapshot, CONTEXT))
    assert time_msg.time_unix_usec == round(EPOCH_START_S * 1e6) + 2_500_000
    assert time_msg.time_boot_ms == 2500


def test_every_builder_packs_a_default_snapshot():
    for builder in messages.BUILDERS.values():
        message = builder(make_snapshot(), CONTEXT)
        assert message is not None
        _packs(message)


def test_statustext_single_message_and_chunks():
    (single,) = messages.statustext_chunks(4, "x" * 50, 9)
    assert (single.id, single.chunk_seq) == (0, 0)
    chunks = messages.statustext_chunks(4, "y" * 100, 9)
    assert [(c.id, c.chunk_seq, len(c.text)) for c in chunks] == [(9, 0, 50), (9, 1, 50), (9, 2, 0)]
    chunks = messages.statustext_chunks(4, "z" * 120, 10)
    assert [len(c.text) for c in chunks] == [50, 50, 20]
    for chunk in chunks:
        _packs(chunk)


def test_position_target_local_ned_marks_uncontrolled_fields_as_ignored():
    """As PX4: NaN setpoint components (velocity-controlled axes, no acceleration, no yaw
    rate) get their *_IGNORE bit; controlled ones are sent as they are."""
    sp = replace(
        make_snapshot().setpoint,
        position_ned_m=(math.nan, math.nan, -10.0),
        velocity_ned_m_s=(1.0, -0.5, 0.0),
    )
    msg = _packs(messages.position_target_local_ned(make_snapshot(setpoint=sp), CONTEXT))
    ignored = (
        mavlink2.POSITION_TARGET_TYPEMASK_X_IGNORE
        | mavlink2.POSITION_TARGET_TYPEMASK_Y_IGNORE
        | mavlink2.POSITION_TARGET_TYPEMASK_AX_IGNORE
        | mavlink2.POSITION_TARGET_TYPEMASK_AY_IGNORE
        | mavlink2.POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | mavlink2.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
    )
    assert msg.type_mask == ignored
    assert msg.coordinate_frame == mavlink2.MAV_FRAME_LOCAL_NED
    assert (msg.z, msg.vx, msg.vy) == (-10.0, 1.0, -0.5)


def test_setpoint_messages_are_not_sent_while_no_controller_runs():
    idle = make_snapshot(setpoint=None)
    for build in (
        messages.attitude_target,
        messages.position_target_local_ned,
        messages.position_target_global_int,
    ):
        assert build(idle, CONTEXT) is None


def test_position_target_global_int_only_for_a_horizontal_position_target():
    snapshot = make_snapshot()
    msg = _packs(messages.position_target_global_int(snapshot, CONTEXT))
    lat, lon, alt = snapshot.setpoint.global_position
    assert (msg.lat_int, msg.lon_int) == (round(lat * 1e7), round(lon * 1e7))
    assert msg.alt == pytest.approx(alt)
    assert msg.coordinate_frame == mavlink2.MAV_FRAME_GLOBAL_INT
    velocity_only = replace(snapshot.setpoint, global_position=(math.nan, math.nan, alt))
    assert (
        messages.position_target_global_int(make_snapshot(setpoint=velocity_only), CONTEXT) is None
    )


@pytest.mark.parametrize("thrust", [-0.2, 0.0, 0.61, 1.7])
def test_attitude_target_thrust_is_collective_thrust_in_0_1(thrust):
    sp = replace(make_snapshot().setpoint, thrust=thrust, attitude_wxyz=(0.0, 1.0, 0.0, 0.0))
    msg = _packs(messages.attitude_target(make_snapshot(setpoint=sp), CONTEXT))
    assert msg.thrust == pytest.approx(min(1.0, max(0.0, thrust)))
    assert list(msg.q) == [0.0, 1.0, 0.0, 0.0]
    assert msg.type_mask == 0  # as PX4: every field is a live setpoint


def test_odometry_is_ned_with_variances_on_the_covariance_diagonals():
    snapshot = make_snapshot(position_ned_m=(1.0, 2.0, -3.0), velocity_ned_m_s=(0.5, 0.0, -0.1))
    msg = _packs(messages.odometry(snapshot, CONTEXT))
    assert (msg.frame_id, msg.child_frame_id) == (mavlink2.MAV_FRAME_LOCAL_NED,) * 2
    assert (msg.x, msg.y, msg.z, msg.vx, msg.vz) == pytest.approx((1.0, 2.0, -3.0, 0.5, -0.1))
    est = snapshot.estimator
    diagonal = [msg.pose_covariance[i] for i in (0, 6, 11)]
    assert diagonal == pytest.approx(est.position_variance_m2)
    assert [msg.velocity_covariance[i] for i in (0, 6, 11)] == pytest.approx(
        est.velocity_variance_m2_s2
    )
    assert math.isnan(msg.pose_covariance[1])  # off-diagonal: unknown
    assert msg.estimator_type == mavlink2.MAV_ESTIMATOR_TYPE_AUTOPILOT


def test_estimator_status_origin_and_highres_imu_fields():
    snapshot = make_snapshot()
    est = _packs(messages.estimator_status(snapshot, CONTEXT))
    assert est.flags == snapshot.estimator.flags
    assert est.pos_horiz_accuracy == pytest.approx(snapshot.estimator.pos_horiz_accuracy_m)
    origin = _packs(messages.gps_global_origin(snapshot, CONTEXT))
    assert (origin.latitude, origin.altitude) == (473977420, 488000)
    assert origin.time_usec == snapshot.estimator.origin_time_usec
    no_origin = replace(snapshot.estimator, origin_lla=None)
    assert messages.gps_global_origin(make_snapshot(estimator=no_origin), CONTEXT) is None
    imu = _packs(messages.highres_imu(snapshot, CONTEXT))
    assert (imu.zacc, imu.abs_pressure, imu.fields_updated) == pytest.approx((-9.81, 955.0, 0x1FFF))
    assert messages.highres_imu(make_snapshot(imu=None), CONTEXT) is None
