"""The autopilot finds the declination of wherever the world is, and heads true north."""

from __future__ import annotations

import numpy as np
import pytest

from autopilot_emu import magnetic_declination, quaternion
from harness.sim.simulation import Simulation, SimulationConfig
from sitl.world import WorldConfig

SYDNEY = {"origin_lat_deg": -33.9, "origin_lon_deg": 151.2, "origin_alt_amsl_m": 30.0}


def _heading_error_deg(world: dict, decl_type: int | None = None) -> tuple[float, float, float]:
    """(estimated - true yaw, world declination, EKF2_MAG_DECL) after 30 s at rest, degrees.

    The estimator aligns its heading with EKF2_MAG_DECL before it has an origin and converges to
    the looked-up declination afterwards (PX4 resets the yaw at once; this filter's heading
    correction takes ~7 s per e-fold at Sydney's inclination), hence the 30 s.
    """
    config = SimulationConfig(mavlink=False, record_hz=0, seed=3, world=WorldConfig(**world))
    with Simulation(config) as sim:
        params = sim.fleet.params[0]
        if decl_type is not None:
            params.set("EKF2_DECL_TYPE", decl_type)
        sim.run_lockstep(30.0)
        estimated = float(quaternion.yaw_of(sim.fleet.estimator.r)[0])
        true = float(sim.world.truth.euler_ned_frd_rad[0, 2])
        error = np.degrees((estimated - true + np.pi) % (2 * np.pi) - np.pi)
        return (
            float(error),
            sim.world.magnetic_field.declination_deg,
            float(params.get("EKF2_MAG_DECL")),
        )


@pytest.mark.parametrize("world", [{}, SYDNEY], ids=["zurich", "sydney"])
def test_the_looked_up_declination_corrects_the_heading(world):
    """Default EKF2_DECL_TYPE against the lookup switched off (EKF2_DECL_TYPE 0, EKF2_MAG_DECL
    0), same seed and so the same sensors: the heading estimates differ by the world's
    declination (3.5 deg in Zurich, 12.8 deg in Sydney), which is nowhere configured in the
    autopilot; the lookup was saved to EKF2_MAG_DECL.

    Both runs share the heading error that the IMU's full turn-on biases cause at rest (a
    horizontal accelerometer bias reads as a tilt until the vehicle manoeuvres, and through the
    field's inclination as a heading offset; EKF2 has the same limit), so the test compares the
    two rather than either with the truth.
    """
    error, declination, saved = _heading_error_deg(world)
    error_off, _, saved_off = _heading_error_deg(world, decl_type=0)
    assert saved_off == 0.0
    assert error - error_off == pytest.approx(declination, abs=1.0)
    assert abs(error) < abs(error_off) or abs(declination) < 5.0
    assert saved == pytest.approx(declination, abs=1.5)
    lat = world.get("origin_lat_deg", 47.397742)
    lon = world.get("origin_lon_deg", 8.545594)
    assert saved == pytest.approx(magnetic_declination.lookup_declination_deg(lat, lon), abs=0.1)
