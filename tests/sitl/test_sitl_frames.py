"""Every frame conversion of sitl.frames, each tested once."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pymap3d
import pytest

from sitl import frames

ORIGIN = frames.GeodeticOrigin(47.397742, 8.545594, 488.0)


def test_enu_ned_swap_axes_and_flip_up():
    """East-north-up (1, 2, 3) is north-east-down (2, 1, -3), and back."""
    v = np.array([[1.0, 2.0, 3.0], [-4.0, 5.0, -6.0]])
    assert np.array_equal(frames.enu_to_ned(v), [[2.0, 1.0, -3.0], [5.0, -4.0, 6.0]])
    assert np.array_equal(frames.ned_to_enu(frames.enu_to_ned(v)), v)


def test_flu_frd_flip_left_and_up():
    """Forward-left-up (1, 2, 3) is forward-right-down (1, -2, -3), and back."""
    v = np.array([1.0, 2.0, 3.0])
    assert np.array_equal(frames.flu_to_frd(v), [1.0, -2.0, -3.0])
    assert np.array_equal(frames.frd_to_flu(frames.flu_to_frd(v)), v)


@pytest.mark.parametrize(
    ("yaw_enu_deg", "px4_yaw_deg"), [(90.0, 0.0), (0.0, 90.0), (180.0, -90.0), (45.0, 45.0)]
)
def test_quaternion_yaw_convention(yaw_enu_deg, px4_yaw_deg):
    """A body whose FLU x points north in ENU has PX4 yaw 0; pointing east, yaw +90 deg."""
    q_xyzw = np.array(p.getQuaternionFromEuler([0.0, 0.0, np.radians(yaw_enu_deg)]))
    euler = frames.euler_from_quat_ned_frd(frames.quat_enu_flu_to_ned_frd(q_xyzw))
    assert euler == pytest.approx([0.0, 0.0, np.radians(px4_yaw_deg)], abs=1e-12)


def test_quaternion_round_trip_and_rotation_agree():
    """Quaternion conversion round-trips and maps body FRD vectors like the two frame changes."""
    rng = np.random.default_rng(3)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q_ned = frames.quat_enu_flu_to_ned_frd(q)
    back = frames.quat_ned_frd_to_enu_flu(q_ned)
    assert np.allclose(np.abs(np.sum(back * q, axis=1)), 1.0)  # same rotation (q ~ -q)
    v_frd = rng.normal(size=(20, 3))
    v_enu = frames.body_frd_to_world_enu(frames.rotation_matrix_xyzw(q), v_frd)
    w, x, y, z = np.moveaxis(q_ned, -1, 0)
    r_ned = frames.rotation_matrix_xyzw(np.stack([x, y, z, w], axis=-1))
    assert np.allclose(frames.enu_to_ned(v_enu), np.einsum("nij,nj->ni", r_ned, v_frd))


def test_euler_round_trip():
    """PX4 Euler angles survive quaternion construction and extraction."""
    angles = (0.1, -0.2, 2.5)
    assert frames.euler_from_quat_ned_frd(frames.quat_from_euler_ned_frd(*angles)) == pytest.approx(
        angles
    )


def test_rotation_matrix_matches_pybullet():
    """Our quaternion -> matrix equals PyBullet's (row-major, body -> world)."""
    q = p.getQuaternionFromEuler([0.3, -0.4, 1.2])
    ours = frames.rotation_matrix_xyzw(np.array(q))
    theirs = np.array(p.getMatrixFromQuaternion(q)).reshape(3, 3)
    assert np.allclose(ours, theirs)


def test_world_to_body_frd():
    """World up seen from a level body facing north is body FRD (0, 0, -1); east is right."""
    r = frames.rotation_matrix_xyzw(np.array(p.getQuaternionFromEuler([0, 0, np.pi / 2])))
    assert frames.world_enu_to_body_frd(r, np.array([0, 0, 1.0])) == pytest.approx([0, 0, -1])
    assert frames.world_enu_to_body_frd(r, np.array([1.0, 0, 0])) == pytest.approx([0, 1, 0])
    stacked = frames.world_enu_to_body_frd(r[None], np.array([[[0, 0, 1.0], [1.0, 0, 0]]]))
    assert stacked == pytest.approx(np.array([[[0, 0, -1], [0, 1, 0]]]))


def test_geodetic_matches_pymap3d_and_round_trips():
    """ENU -> geodetic agrees with pymap3d to < 1e-5 m within 20 km, and inverts to < 1e-5 m."""
    rng = np.random.default_rng(7)
    enu = rng.uniform([-20e3, -20e3, -100.0], [20e3, 20e3, 3000.0], size=(200, 3))
    lat, lon, alt = frames.enu_to_geodetic(enu, ORIGIN)
    ref_lat, ref_lon, _ = pymap3d.enu2geodetic(
        enu[:, 0], enu[:, 1], enu[:, 2], ORIGIN.lat_deg, ORIGIN.lon_deg, ORIGIN.alt_amsl_m
    )
    assert np.max(np.abs(lat - ref_lat)) < 1e-10  # degrees: ~1e-5 m
    assert np.max(np.abs(lon - ref_lon)) < 1e-10
    assert np.allclose(alt, ORIGIN.alt_amsl_m + enu[:, 2])  # flat ground: altitude is up
    assert np.max(np.abs(frames.geodetic_to_enu(lat, lon, alt, ORIGIN) - enu)) < 1e-5
    lat0, lon0, alt0 = frames.enu_to_geodetic(np.zeros(3), ORIGIN)
    assert (float(lat0), float(lon0), float(alt0)) == pytest.approx(
        (ORIGIN.lat_deg, ORIGIN.lon_deg, ORIGIN.alt_amsl_m), abs=1e-12
    )
