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


DATASHEET_DENSITIES = {
    # airframe: (accelerometer ug/sqrt(Hz), gyroscope mdeg/s/sqrt(Hz)) of its IMU class.
    # Typhoon H480: PX4 gazebo-classic typhoon_h480.sdf.jinja gazebo_imu_plugin block,
    # accelerometerNoiseDensity 0.004 m/s^2/sqrt(Hz) = 407.9 ug/sqrt(Hz) (1 g = 9.80665 m/s^2),
    # gyroscopeNoiseDensity 0.0003394 rad/s/sqrt(Hz) = 19.45 mdeg/s/sqrt(Hz).
    "typhoon_h480": (0.004 / 9.80665e-6, np.degrees(0.0003394) * 1e3),
    # x500: TDK ICM-42688-P datasheet DS-000347, Table 2 accelerometer power spectral density
    # 70 ug/sqrt(Hz) (Z; X and Y 65, modelled at 70), Table 1 rate noise spectral density
    # 0.0028 deg/s/sqrt(Hz).
    "x500": (70.0, 2.8),
}
DENSITY_REL_BOUND = 0.04
"""Each axis' measured density within 4 % of the datasheet's: 1.6 x the worst of the 24
estimates per airframe (2.5 %; one estimate from 5000 samples scatters ~1 %)."""


def _allan_variance(x: np.ndarray, m: int) -> float:
    """Overlapping Allan variance of samples ``x`` at cluster size ``m``."""
    c = np.cumsum(np.concatenate(([0.0], x)))
    means = (c[m:] - c[:-m]) / m
    return 0.5 * float(np.mean((means[m:] - means[:-m]) ** 2))


def white_noise_density(x: np.ndarray, dt_s: float) -> float:
    """Angle/velocity random walk N of samples ``x`` (unit/sqrt(Hz)) from their Allan variance.

    Fits AVAR(tau) = N^2 / tau + K^2 tau / 3 (white noise plus a bias random walk, IEEE Std
    952-1997 Annex C) over tau = 1..64 samples, relative errors weighted equally.
    """
    ms = np.array([1, 2, 4, 8, 16, 32, 64])
    tau = ms * dt_s
    avar = np.array([_allan_variance(x, int(m)) for m in ms])
    design = np.column_stack((1.0 / tau, tau / 3.0)) / avar[:, None]
    coef, *_ = np.linalg.lstsq(design, np.ones_like(avar), rcond=None)
    return float(np.sqrt(coef[0]))


@pytest.mark.parametrize("airframe", sorted(DATASHEET_DENSITIES))
def test_imu_noise_density_at_rest_is_the_datasheet_figure(airframe):
    """Four vehicles at rest for 20 s: each axis' white-noise density, from the Allan variance of
    the 250 Hz HIL_SENSOR samples, is its IMU class's published figure."""
    world = make_world(airframe=airframe, n_vehicles=4, seed=3)
    sensors, _ = collect(world, 20.0)
    world.close()
    accel_ug, gyro_mdps = DATASHEET_DENSITIES[airframe]
    measured = []
    for vehicle in range(4):
        imu = sensor_array(sensors, vehicle, IMU)[1:]
        for axis in range(3):
            accel = white_noise_density(imu[:, axis], 1.0 / 250.0) / 9.80665e-6
            gyro = np.degrees(white_noise_density(imu[:, 3 + axis], 1.0 / 250.0)) * 1e3
            measured.append((accel, gyro))
            assert accel == pytest.approx(accel_ug, rel=DENSITY_REL_BOUND)
            assert gyro == pytest.approx(gyro_mdps, rel=DENSITY_REL_BOUND)
    a, g = np.array(measured).T
    print(f"{airframe}: accel {a.min():.1f}-{a.max():.1f} ug/rtHz (class {accel_ug}), "
          f"gyro {g.min():.2f}-{g.max():.2f} mdeg/s/rtHz (class {gyro_mdps})")  # fmt: skip


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


NEO_M9N_CEP50_M = 1.5
"""u-blox NEO-M9N data sheet UBX-19014285, horizontal PVT accuracy 1.5 m CEP (50 %, 24 h static,
-130 dBm, > 6 satellites): the Typhoon H480's receiver class."""
SIGMA_M = NEO_M9N_CEP50_M / 1.1774
"""Per-axis standard deviation of a circular Gaussian with that CEP50, m."""


def test_gps_near_the_origin_at_rest(at_rest):
    """3D fix near the origin, velocity ~0; eph of the order of the receiver's datasheet
    accuracy (1.27 m per axis), epv larger."""
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
    # 3 CEP50 = 3.5 sigma: a Rayleigh radius exceeds it with probability 0.2 %.
    assert np.all(np.hypot(north_m, east_m) < 3.0 * NEO_M9N_CEP50_M)
    # Vertically 4 x 1.6 sigma x sqrt(2) (VDOP / HDOP, eph per axis): 0.01 %.
    assert np.all(np.abs(alt - (488.0 + world.airframe.ground_clearance_m)) < 11.5)
    vel = np.array([[m.vn, m.ve, m.vd] for m in msgs]) / 100.0
    assert np.all(np.abs(vel.mean(axis=0)) < 0.1)
    assert np.all(vel.std(axis=0) < 0.3)
    # Satellites 8..24 scale HDOP by sqrt(12 / (n - 2)): 1.41 .. 0.74 of the reference.
    eph_m = np.array([m.eph for m in msgs]) / 100.0
    epv_m = np.array([m.epv for m in msgs]) / 100.0
    assert np.all((eph_m >= 0.7 * SIGMA_M) & (eph_m <= 1.45 * SIGMA_M))
    assert np.all(epv_m > eph_m)  # GNSS geometry: vertical worse than horizontal
    assert all(m.cog == 65535 or 0 <= m.cog < 36000 for m in msgs)
    assert sum(m.cog == 65535 for m in msgs) > len(msgs) / 2  # unknown when nearly still


def test_gps_tracks_a_falling_vehicle():
    """Falling with motors off, GPS down velocity and altitude follow free fall with quadratic
    drag at the measurement time: the fix sent at 2 s was measured the receiver's delay earlier."""
    world = make_world(spawn_altitude_m=50.0, seed=2)
    _, gps = collect(world, 2.0, [actuator_message([0.0] * 6, armed=False)])
    last = gps[-1][0]
    t = 2.0 - world.airframe.gps.delay_ms * 1e-3
    k = world.airframe.fuselage.coefficients_n_s2_m2()[2] / world.airframe.mass_kg
    terminal = np.sqrt(9.81 / k)
    assert last.vd / 100.0 == pytest.approx(terminal * np.tanh(t * 9.81 / terminal), abs=0.5)
    fallen_m = terminal**2 / 9.81 * np.log(np.cosh(t * 9.81 / terminal))
    # Within 4 x the fix's own reported vertical accuracy (epv, 1 sigma, cm).
    assert last.alt / 1000.0 == pytest.approx(488.0 + 50.0 - fallen_m, abs=4.0 * last.epv / 100.0)
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
