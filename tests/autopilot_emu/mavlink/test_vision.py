"""VISION_POSITION_ESTIMATE / ODOMETRY decoding, and the endpoint passing them to the vehicle."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from autopilot_emu.mavlink.vision import (
    VisionError,
    decode_odometry,
    decode_vision_position_estimate,
)

pytestmark = pytest.mark.sockets

NAN21 = [math.nan] * 21


def _covariance(pos_var: tuple[float, float, float], yaw_var: float) -> list[float]:
    """Upper triangle of a diagonal 6x6 pose covariance (x, y, z, roll, pitch, yaw)."""
    cov = [0.0] * 21
    for index, value in zip((0, 6, 11, 15, 18, 20), (*pos_var, 0.01, 0.01, yaw_var), strict=True):
        cov[index] = value
    return cov


def _vpe(x=1.0, y=-2.0, z=-3.0, yaw=0.5, covariance=None):
    cov = _covariance((0.01, 0.02, 0.03), 0.004) if covariance is None else covariance
    return mavlink2.MAVLink_vision_position_estimate_message(
        1_000_000, x, y, z, 0.01, -0.02, yaw, cov, 0
    )


def _odometry(
    frame=mavlink2.MAV_FRAME_LOCAL_NED,
    child=mavlink2.MAV_FRAME_BODY_FRD,
    position=(1.0, 2.0, -3.0),
    yaw=math.pi / 2,
    velocity=(1.0, 0.0, 0.0),
    covariance=None,
    estimator=mavlink2.MAV_ESTIMATOR_TYPE_VISION,
):
    q = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    cov = _covariance((0.04, 0.05, 0.06), 0.01) if covariance is None else covariance
    return mavlink2.MAVLink_odometry_message(
        2_000_000,
        frame,
        child,
        *position,
        q,
        *velocity,
        0.0,
        0.0,
        0.0,
        cov,
        NAN21,
        0,
        estimator,
        100,
    )


def test_vision_position_estimate_is_local_ned_with_diagonal_variances():
    """Position as sent; variances from covariance entries 0, 6, 11 and yaw's from 20."""
    m = decode_vision_position_estimate(_vpe())
    np.testing.assert_allclose(m.position_ned_m, [1.0, -2.0, -3.0])
    np.testing.assert_allclose(m.position_var_m2, [0.01, 0.02, 0.03], rtol=1e-6)
    assert m.yaw_rad == pytest.approx(0.5)
    assert m.yaw_var_rad2 == pytest.approx(0.004)
    assert m.velocity_ned_m_s is None


def test_unknown_covariance_gives_nan_variances():
    """NaN in the first covariance entry means unknown: every variance NaN (the EKF's own
    EKF2_EVP_NOISE / EKF2_EVA_NOISE then apply)."""
    m = decode_vision_position_estimate(_vpe(covariance=NAN21))
    assert np.isnan(m.position_var_m2).all() and math.isnan(m.yaw_var_rad2)


@pytest.mark.parametrize(
    ("message", "reason"),
    [
        (_vpe(x=math.nan), "non-finite position"),
        (_vpe(covariance=_covariance((-1.0, 0.1, 0.1), 0.1)), "negative position variance"),
        (_odometry(position=(0.0, math.inf, 0.0)), "non-finite position"),
        (_odometry(frame=mavlink2.MAV_FRAME_GLOBAL), "unsupported frame"),
        (_odometry(estimator=mavlink2.MAV_ESTIMATOR_TYPE_GPS), "unsupported estimator_type"),
        (_odometry(estimator=mavlink2.MAV_ESTIMATOR_TYPE_MOCAP), "not fused by EKF2"),
    ],
)
def test_malformed_messages_are_refused_with_a_reason(message, reason):
    """NaN positions, negative variances, wrong frames and estimator types raise VisionError."""
    decode = (
        decode_odometry if message.get_type() == "ODOMETRY" else decode_vision_position_estimate
    )
    with pytest.raises(VisionError, match=reason):
        decode(message)


def test_odometry_body_velocity_is_rotated_into_the_local_frame():
    """Heading east (yaw 90 deg), 1 m/s forward in body FRD is 1 m/s east in NED."""
    m = decode_odometry(_odometry())
    np.testing.assert_allclose(m.position_ned_m, [1.0, 2.0, -3.0])
    np.testing.assert_allclose(m.velocity_ned_m_s, [0.0, 1.0, 0.0], atol=1e-12)
    assert m.yaw_rad == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(m.position_var_m2, [0.04, 0.05, 0.06], rtol=1e-6)
    assert m.yaw_var_rad2 == pytest.approx(0.01)


def test_odometry_frames_and_naive_estimator():
    """LOCAL_FRD passes through; ENU is swapped to NED (and its quaternion's heading dropped);
    a local velocity frame is used as is; NAIVE ignores covariances, NaN velocity is absent."""
    frd = decode_odometry(
        _odometry(frame=mavlink2.MAV_FRAME_LOCAL_FRD, child=mavlink2.MAV_FRAME_LOCAL_FRD)
    )
    np.testing.assert_allclose(frd.position_ned_m, [1.0, 2.0, -3.0])
    np.testing.assert_allclose(frd.velocity_ned_m_s, [1.0, 0.0, 0.0])
    enu = decode_odometry(_odometry(frame=mavlink2.MAV_FRAME_LOCAL_ENU))
    np.testing.assert_allclose(enu.position_ned_m, [2.0, 1.0, 3.0])
    assert math.isnan(enu.yaw_rad) and enu.velocity_ned_m_s is None
    naive = decode_odometry(
        _odometry(estimator=mavlink2.MAV_ESTIMATOR_TYPE_NAIVE, velocity=(math.nan,) * 3)
    )
    assert np.isnan(naive.position_var_m2).all() and math.isnan(naive.yaw_var_rad2)
    assert naive.velocity_ned_m_s is None


def test_endpoint_passes_vision_to_the_vehicle_and_counts_rejects(
    client, vehicle, endpoint, caplog
):
    """A good VPE reaches vehicle.vision_measurement stamped with the arrival time; malformed
    ones are counted and logged once per reason."""
    endpoint.poll(0.0)
    client.send(endpoint, _vpe())
    endpoint.poll(1.5)
    calls = [c for c in vehicle.calls if c[0] == "vision_measurement"]
    assert len(calls) == 1
    _, time_usec, position, variance, yaw, yaw_var, velocity = calls[0]
    assert time_usec == 1_500_000
    np.testing.assert_allclose(position, [1.0, -2.0, -3.0])
    np.testing.assert_allclose(variance, [0.01, 0.02, 0.03], rtol=1e-6)
    assert yaw == pytest.approx(0.5) and yaw_var == pytest.approx(0.004) and velocity is None
    with caplog.at_level(logging.WARNING, logger="autopilot_emu.mavlink.vision"):
        for k in range(3):
            client.send(endpoint, _vpe(x=math.nan))
            client.send(endpoint, _odometry(frame=mavlink2.MAV_FRAME_GLOBAL))
            endpoint.poll(1.6 + 0.01 * k)
    assert endpoint.stats.vision_received == 1
    assert endpoint.stats.vision_ignored == 6
    warnings = [r.getMessage() for r in caplog.records if "ignoring" in r.getMessage()]
    assert len(warnings) == 2
    assert sum(c[0] == "vision_measurement" for c in vehicle.calls) == 1
