"""HIL_SENSOR / HIL_GPS content, rates, noise statistics and determinism."""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2
from sitl_test_helpers import actuator_message, collect, make_world, sensor_array

from sitl import hil
from sitl.physics.earth import isa_pressure_pa

IMU = ("xacc", "yacc", "zacc", "xgyro", "ygyro", "zgyro")


@pytest.fixture(scope="module")
def at_rest():
    """Five seconds on the ground, motors off: (world, sensor batches, gps batches)."""
    world = make_world(seed=1)
    first_sensors, first_gps = world.poll_sensors()  # t = 0 is due too
    sensors, gps = collect(world, 5.0)
    yield world, [first_sensors, *sensors], [first_gps, *gps]
    world.close()


def test_rates_and_flags(at_rest):
    """HIL_SENSOR at 250 Hz with mag flagged at 100 Hz and baro at 50 Hz; HIL_GPS at 10 Hz."""
    _, sensors, gps = at_rest
    assert len(sensors) == 5 * 250 + 1 and len(gps) == 5 * 10 + 1
    flags = np.array([batch[0].fields_updated for batch in sensors])
    assert np.all(flags & hil.FIELDS_IMU == 0x3F)
    assert np.sum((flags & hil.FIELDS_MAG) == hil.FIELDS_MAG) == 5 * 100 + 1
    assert np.sum((flags & hil.FIELDS_BARO) == hil.FIELDS_BARO) == 5 * 50 + 1
    assert hil.FIELDS_MAG == 0x1C0 and hil.FIELDS_BARO == 0x200 | 0x800 | 0x1000
    times = np.array([batch[0].time_usec for batch in sensors])
    assert np.all(np.diff(times) == 4000)
    assert [batch[0].time_usec for batch in gps[:3]] == [0, 100_000, 200_000]


def test_accelerometer_and_gyro_at_rest(at_rest):
    """At rest level: specific force (0, 0, -g) FRD plus the accelerometer bias, gyro mean = its
    bias (the full turn-on biases, turn_on_bias_scale 1.0, are up to a few tenths of m/s²)."""
    world, sensors, _ = at_rest
    imu = sensor_array(sensors, 0, IMU)
    sensor = world._groups[0].imu if hasattr(world, "_groups") else world._imu  # private state
    bias = sensor.noise.turn_on_bias[0] + sensor.noise.bias[0]
    assert imu[:, :3].mean(axis=0) - bias[0] == pytest.approx([0.0, 0.0, -9.81], abs=0.02)
    assert np.all(np.abs(imu[:, 3:].mean(axis=0) - bias[1]) < 0.001)


def test_gyro_and_accel_white_noise_match_density(at_rest):
    """Std at 250 Hz = noise density * sqrt(250 Hz) within 15 %."""
    world, sensors, _ = at_rest
    imu = sensor_array(sensors, 0, IMU)[1:]
    params = world.airframe.imu
    gyro_sigma = params.gyro_noise_density_rad_s_sqrt_hz * np.sqrt(250.0)
    accel_sigma = params.accel_noise_density_m_s2_sqrt_hz * np.sqrt(250.0)
    assert imu[:, 3:].std(axis=0) == pytest.approx([gyro_sigma] * 3, rel=0.15)
    assert imu[:, :3].std(axis=0) == pytest.approx([accel_sigma] * 3, rel=0.15)


def test_magnetometer_reads_the_configured_field(at_rest):
    """Facing north, level: FRD field = (H cos D, H sin D, F sin I), gauss."""
    world, sensors, _ = at_rest
    field = world.magnetic_field
    mag = sensor_array(sensors, 0, ("xmag", "ymag", "zmag"))
    inc, dec = np.radians(field.inclination_deg), np.radians(field.declination_deg)
    h = field.strength_gauss * np.cos(inc)
    expected = [h * np.cos(dec), h * np.sin(dec), field.strength_gauss * np.sin(inc)]
    assert mag.mean(axis=0) == pytest.approx(expected, abs=0.002)


def test_barometer_is_isa_at_the_vehicle_altitude(at_rest):
    """Pressure ~ ISA at 488 m + CoM height (about 955 hPa); temperature ISA in deg C."""
    world, sensors, _ = at_rest
    baro = sensor_array(sensors, 0, ("abs_pressure", "pressure_alt", "temperature"))
    alt = 488.0 + world.airframe.ground_clearance_m
    assert baro[:, 0].mean() == pytest.approx(isa_pressure_pa(alt) / 100.0, abs=0.01)
    assert baro[:, 0].mean() == pytest.approx(955.0, abs=1.0)
    assert baro[:, 1].mean() == pytest.approx(alt, abs=0.1)
    assert baro[:, 2].mean() == pytest.approx(15.0 - 0.0065 * alt, abs=0.01)
    assert all(batch[0].diff_pressure == 0.0 for batch in sensors)


def test_gps_near_the_origin_at_rest(at_rest):
    """3D fix near the origin (error of order 0.5 m horizontal, 1 m vertical), velocity ~0."""
    world, _, gps = at_rest
    # The first two sends precede the first fix, measured 120 ms before it is sent.
    assert [m.fix_type for m in (gps[0][0], gps[1][0])] == [1, 1]
    msgs = [batch[0] for batch in gps[2:]]
    assert all(m.fix_type == 3 and 8 <= m.satellites_visible <= 24 for m in msgs)
    lat = np.array([m.lat for m in msgs]) * 1e-7
    lon = np.array([m.lon for m in msgs]) * 1e-7
    alt = np.array([m.alt for m in msgs]) * 1e-3
    north_m = (lat - world.config.origin_lat_deg) * 111_200.0
    east_m = (lon - world.config.origin_lon_deg) * 111_200.0 * np.cos(np.radians(47.4))
    assert np.all(np.hypot(north_m, east_m) < 3.0)
    assert np.all(np.abs(alt - (488.0 + world.airframe.ground_clearance_m)) < 5.0)
    vel = np.array([[m.vn, m.ve, m.vd] for m in msgs]) / 100.0
    assert np.all(np.abs(vel.mean(axis=0)) < 0.1)
    assert np.all(vel.std(axis=0) < 0.3)
    assert all(20 <= m.eph <= 100 and 50 <= m.epv <= 250 for m in msgs)  # 1-sigma errors, cm
    assert all(m.cog == 65535 or 0 <= m.cog < 36000 for m in msgs)
    assert sum(m.cog == 65535 for m in msgs) > len(msgs) / 2  # unknown when nearly still


def test_gps_tracks_a_falling_vehicle():
    """Falling with motors off, GPS down velocity follows g t (less the quadratic drag), t the
    measurement time: the fix sent at 2 s was measured the receiver's delay earlier."""
    world = make_world(spawn_altitude_m=50.0, seed=2)
    _, gps = collect(world, 2.0, [actuator_message([0.0] * 6, armed=False)])
    last = gps[-1][0]
    t = 2.0 - world.airframe.gps.delay_ms * 1e-3
    k = world.airframe.fuselage.coefficients_n_s2_m2()[2] / world.airframe.mass_kg
    terminal = np.sqrt(9.81 / k)
    assert last.vd / 100.0 == pytest.approx(terminal * np.tanh(t * 9.81 / terminal), abs=0.5)
    assert last.alt / 1000.0 == pytest.approx(488.0 + 50.0 - 0.5 * 9.81 * t * t, abs=5.0)
    world.close()


def test_messages_pack_as_mavlink2():
    """Every message built packs into a MAVLink 2 frame (right field types and ranges)."""
    world = make_world(n_vehicles=2)
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    sensors, gps = world.poll_sensors()
    for msg in sensors + gps:
        decoded = mav.decode(bytearray(msg.pack(mav)))
        assert decoded.get_type() == msg.get_type()
    assert all(isinstance(m, mavlink2.MAVLink_hil_sensor_message) and m.id == 0 for m in sensors)
    assert all(isinstance(m, mavlink2.MAVLink_hil_gps_message) for m in gps)
    assert world.poll_sensors() == (None, None)  # nothing new at the same time
    world.close()


def _run_messages(seed: int) -> list[bytes]:
    world = make_world(n_vehicles=2, seed=seed, spawn_altitude_m=5.0)
    mav = mavlink2.MAVLink(None)
    out = []
    command = [actuator_message([0.5] * 6), None]
    for _ in range(300):
        world.step(command)
        sensors, gps = world.poll_sensors()
        for msg in (sensors or []) + (gps or []):
            out.append(bytes(msg.pack(mav)))
    world.close()
    return out


def test_same_seed_same_messages_different_seed_different():
    """Determinism: a seed fixes every byte of every message; another seed changes them."""
    first = _run_messages(5)
    assert first == _run_messages(5)
    assert first != _run_messages(6)
