"""Decoding of offboard setpoint messages: MAVSDK's type_masks and frames, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.setpoints import (
    SetpointError,
    decode_attitude,
    decode_global,
    decode_local,
)
from autopilot_emu.modes.offboard import AltitudeReference, LocalFrame

LOCAL_NED, BODY_NED = mavlink2.MAV_FRAME_LOCAL_NED, mavlink2.MAV_FRAME_BODY_NED


def local(mask: int, frame: int = LOCAL_NED, values=None) -> mavlink2.MAVLink_message:
    v = values or (1.0, 2.0, -3.0, 0.4, 0.5, 0.6, 0.1, 0.2, 0.3, 1.2, 0.7)
    return mavlink2.MAVLink_set_position_target_local_ned_message(0, 1, 1, frame, mask, *v)


def attitude(mask: int, q=(1.0, 0.0, 0.0, 0.0), rates=(0.1, 0.2, 0.3), thrust=0.6):
    return mavlink2.MAVLink_set_attitude_target_message(0, 1, 1, mask, q, *rates, thrust)


def test_mavsdk_position_ned():
    """set_position_ned: 0x09F8 = position and yaw."""
    sp, frame = decode_local(local(0x09F8))
    assert frame == LocalFrame.LOCAL_NED
    assert sp.position_ned_m.tolist() == [1.0, 2.0, -3.0]
    assert np.isnan(sp.velocity_ned_m_s).all() and np.isnan(sp.acceleration_ned_m_s2).all()
    assert sp.yaw_rad == pytest.approx(1.2) and math.isnan(sp.yaw_rate_rad_s)


def test_mavsdk_velocity_ned():
    """set_velocity_ned: 0x09C7 = velocity and yaw."""
    sp, _ = decode_local(local(0x09C7))
    assert np.isnan(sp.position_ned_m).all()
    assert sp.velocity_ned_m_s == pytest.approx([0.4, 0.5, 0.6])
    assert sp.yaw_rad == pytest.approx(1.2)


def test_mavsdk_velocity_body():
    """set_velocity_body: BODY_NED, 0x05C7 = velocity and yaw rate."""
    sp, frame = decode_local(local(0x05C7, BODY_NED))
    assert frame == LocalFrame.BODY_NED
    assert sp.velocity_ned_m_s == pytest.approx([0.4, 0.5, 0.6])
    assert math.isnan(sp.yaw_rad) and sp.yaw_rate_rad_s == pytest.approx(0.7)


def test_position_velocity_and_acceleration():
    sp, _ = decode_local(local(0x0800))  # everything but the yaw rate
    assert np.isfinite(sp.position_ned_m).all() and np.isfinite(sp.velocity_ned_m_s).all()
    assert sp.acceleration_ned_m_s2 == pytest.approx([0.1, 0.2, 0.3])


def test_per_axis_masks():
    sp, _ = decode_local(local(0b1101_1111_1011))  # only z position
    assert np.isnan(sp.position_ned_m[:2]).all() and sp.position_ned_m[2] == -3.0


@pytest.mark.parametrize(
    ("msg", "reason"),
    [
        (local(0x0FFF), "ignores position, velocity and acceleration"),
        (local(0x0DFF), "ignores position, velocity and acceleration"),  # yaw alone
        (local(0x023F), "force"),
        (local(0x09F8, frame=mavlink2.MAV_FRAME_GLOBAL), "unsupported frame"),
        (local(0x09F8, values=(math.nan, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0)), "non-finite"),
        (local(0x09F8, values=(0, 0, 0, 0, 0, 0, 0, 0, 0, math.inf, 0)), "non-finite"),
    ],
)
def test_unflyable_local_setpoints_are_refused(msg, reason):
    with pytest.raises(SetpointError, match=reason):
        decode_local(msg)


def test_nan_in_an_ignored_field_is_fine():
    values = (1.0, 2.0, 3.0, math.nan, math.nan, math.nan, math.nan, 0, 0, 0.5, math.nan)
    sp, _ = decode_local(local(0x09F8, values=values))
    assert sp.position_ned_m.tolist() == [1.0, 2.0, 3.0]


@pytest.mark.parametrize(
    ("frame", "reference"),
    [
        (mavlink2.MAV_FRAME_GLOBAL_INT, AltitudeReference.AMSL),
        (mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, AltitudeReference.HOME),
        (mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, AltitudeReference.TERRAIN),
    ],
)
def test_mavsdk_position_global(frame, reference):
    msg = mavlink2.MAVLink_set_position_target_global_int_message(
        0, 1, 1, frame, 0x09F8, 473977420, 85455940, 12.5, 0, 0, 0, 0, 0, 0, 0.5, 0
    )
    target = decode_global(msg)
    assert target.lat_deg == pytest.approx(47.397742)
    assert target.lon_deg == pytest.approx(8.545594)
    assert target.alt_m == 12.5 and target.reference == reference
    assert target.setpoint.yaw_rad == 0.5


def test_global_refuses_a_lone_latitude_and_bad_frames():
    half = mavlink2.MAVLink_set_position_target_global_int_message(
        0, 1, 1, 6, 0x09FA, 473977420, 85455940, 12.5, 0, 0, 0, 0, 0, 0, 0, 0
    )
    with pytest.raises(SetpointError, match="both"):
        decode_global(half)
    local_frame = mavlink2.MAVLink_set_position_target_global_int_message(
        0, 1, 1, LOCAL_NED, 0x09F8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
    )
    with pytest.raises(SetpointError, match="frame"):
        decode_global(local_frame)


def test_mavsdk_attitude():
    """set_attitude: 0x07 = attitude and thrust, body rates ignored."""
    q = (0.9659, 0.2588, 0.0, 0.0)
    sp = decode_attitude(attitude(0x07, q=q, thrust=0.6))
    assert sp.attitude_wxyz == pytest.approx(np.array(q) / np.linalg.norm(q))
    assert sp.body_rates_rad_s is None and sp.thrust == pytest.approx(0.6)


def test_mavsdk_attitude_rate():
    """set_attitude_rate: 0x80 = body rates and thrust, attitude ignored."""
    sp = decode_attitude(attitude(0x80, q=(0, 0, 0, 0), thrust=0.5))
    assert sp.attitude_wxyz is None
    assert sp.body_rates_rad_s == pytest.approx([0.1, 0.2, 0.3])


def test_thrust_is_clamped_and_may_be_ignored():
    assert decode_attitude(attitude(0x07, thrust=1.7)).thrust == 1.0
    assert math.isnan(decode_attitude(attitude(0x47, thrust=math.nan)).thrust)


@pytest.mark.parametrize(
    ("msg", "reason"),
    [
        (attitude(0x07, q=(0, 0, 0, 0)), "quaternion"),
        (attitude(0x07, q=(math.nan, 0, 0, 1)), "quaternion"),
        (attitude(0xC7), "ignores attitude, rates and thrust"),
        (attitude(0x07, thrust=math.nan), "non-finite"),
        (attitude(0x80, rates=(0.1, math.nan, 0.0)), "non-finite"),
    ],
)
def test_unflyable_attitude_setpoints_are_refused(msg, reason):
    with pytest.raises(SetpointError, match=reason):
        decode_attitude(msg)


floats = st.floats(allow_nan=True, allow_infinity=True, width=32)


@settings(max_examples=300, deadline=None)
@given(
    mask=st.integers(0, 0xFFFF),
    frame=st.integers(0, 255),
    values=st.tuples(*[floats] * 11),
    q=st.tuples(*[floats] * 4),
    ints=st.tuples(st.integers(-(2**31), 2**31 - 1), st.integers(-(2**31), 2**31 - 1)),
)
def test_decoders_only_ever_raise_setpoint_error(mask, frame, values, q, ints):
    """Whatever a client sends, decoding succeeds with finite used fields or says why not."""
    msgs = [
        (decode_local, local(mask, frame, values)),
        (
            decode_global,
            mavlink2.MAVLink_set_position_target_global_int_message(
                0, 1, 1, frame, mask, *ints, *values[2:]
            ),
        ),
        (decode_attitude, attitude(mask & 0xFF, q=q, rates=values[:3], thrust=values[3])),
    ]
    for decode, msg in msgs:
        try:
            out = decode(msg)
        except SetpointError:
            continue
        sp = out[0] if isinstance(out, tuple) else getattr(out, "setpoint", out)
        for field in (sp.position_ned_m, sp.velocity_ned_m_s, sp.acceleration_ned_m_s2):
            assert not np.isinf(field).any()
        if sp.attitude_wxyz is not None:
            assert np.linalg.norm(sp.attitude_wxyz) == pytest.approx(1.0)
