"""GNSS receiver: delay, satellites, accuracy that matches the error, fix type and outages."""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2
from sitl_test_helpers import actuator_message, collect, make_world

from sitl import frames, hil
from sitl.sensors.gps import FIX_2D, FIX_3D, FIX_NONE, Gps, GpsOutages, GpsSample
from sitl.vehicles.multirotor import load_airframe

PARAMS = load_airframe("typhoon_h480").gps
ORIGIN = frames.GeodeticOrigin(47.397742, 8.545594, 488.0)


def _receivers(n: int, seed: int = 0, outages: GpsOutages | None = None, **changes) -> Gps:
    import dataclasses

    params = dataclasses.replace(PARAMS, **changes)
    rng = np.random.default_rng(seed)
    return Gps(params, ORIGIN, n, rng, outages, physics_hz=500.0, gps_hz=10.0)


def _run_still(gps: Gps, epochs: int, dt_s: float = 0.1) -> list[GpsSample]:
    """Receivers held at the origin, one measurement every ``dt_s``."""
    n = gps.satellite_process.value.shape[0]
    zeros = np.zeros((n, 3))
    return [gps.measure(k * dt_s, zeros, zeros, dt_s) for k in range(epochs)]


def test_fix_is_delayed_by_the_receiver_delay():
    """A falling vehicle's GPS down speed matches the truth ~120 ms before the send time."""
    world = make_world(spawn_altitude_m=80.0, seed=3)
    off = [actuator_message([0.0] * 6, armed=False)]
    times, truth_vd, sent = [], [], []
    for _ in range(round(2.5 * world.config.physics_hz)):
        world.step(off)
        _, gps = world.poll_sensors()
        times.append(world.time_s)
        truth_vd.append(-world.truth.velocity_enu_m_s[0, 2])
        if gps is not None and gps[0].fix_type == 3:
            sent.append((gps[0].time_usec * 1e-6, gps[0].vd / 100.0))
    world.close()
    t_send, vd = np.array(sent).T
    lags = np.arange(0.0, 0.301, 0.002)
    rms = [np.sqrt(np.mean((np.interp(t_send - lag, times, truth_vd) - vd) ** 2)) for lag in lags]
    best = lags[int(np.argmin(rms))]
    assert best == pytest.approx(PARAMS.delay_ms * 1e-3, abs=0.01)
    # Without the delay the error would be g * 0.12 s ~ 1.2 m/s, far above the 0.15 m/s noise.
    assert rms[0] > 5 * min(rms)


def test_scripted_outage_reports_no_fix_and_recovers():
    """Fixes measured inside a window [1, 2) s, sent 120 ms later, report no fix, 0 satellites,
    unknown accuracy; only the vehicle named is affected; the fix returns afterwards."""
    outages = GpsOutages(windows=((1.0, 2.0, 1),))
    world = make_world(n_vehicles=2, gps_outages=outages)
    _, gps = collect(world, 3.0)
    world.close()
    delay = PARAMS.delay_ms * 1e-3
    for batch in gps:
        t = batch[0].time_usec * 1e-6
        if t < delay:
            continue
        lost = 1.0 <= t - delay < 2.0
        m0, m1 = batch
        assert m0.fix_type == 3
        if lost:
            assert (m1.fix_type, m1.satellites_visible, m1.eph, m1.epv) == (1, 0, 65535, 65535)
            assert (m1.lat, m1.lon) == (0, 0)
        else:
            assert m1.fix_type == 3 and m1.satellites_visible >= 4 and m1.eph < 65535
    # 10 sends in the window, and the one at 0.1 s (before the first fix, measured at 0.08 s).
    assert sum(batch[1].fix_type == 1 for batch in gps) == 10 + 1


def test_random_outages_match_their_mean_interval_and_duration():
    """Two-state process: fraction of time lost ~ d / (i + d), mean outage length ~ d."""
    interval_s, duration_s, dt = 20.0, 5.0, 0.1
    gps = _receivers(
        200, seed=4, outages=GpsOutages(mean_interval_s=interval_s, mean_duration_s=duration_s)
    )
    lost = np.array([s.fix_type == FIX_NONE for s in _run_still(gps, 3000)])  # 300 s
    assert lost.mean() == pytest.approx(duration_s / (interval_s + duration_s), rel=0.1)
    starts = np.sum(lost[1:] & ~lost[:-1])
    assert lost[1:].sum() * dt / starts == pytest.approx(duration_s, rel=0.1)
    never = _receivers(200, seed=4)
    assert not any((s.fix_type == FIX_NONE).any() for s in _run_still(never, 300))


def test_reported_accuracy_is_the_error_spread():
    """(error / eph) per horizontal axis and (error / epv) vertically have unit std; eph follows
    HDOP x UERE / sqrt(2) of the satellite count. The receivers are independent here
    (common_error_fraction 0): one receiver's error has the same spread whatever share of it
    the world's receivers have in common, and 400 independent ones measure it faster."""
    gps = _receivers(400, seed=5, common_error_fraction=0.0)
    samples = _run_still(gps, 1200, dt_s=1.0)[::20]  # 20 min, every 20 s
    enu = np.stack(
        [frames.geodetic_to_enu(s.lat_deg, s.lon_deg, s.alt_amsl_m, ORIGIN) for s in samples]
    )
    eph = np.stack([s.eph_m for s in samples])
    epv = np.stack([s.epv_m for s in samples])
    assert np.std(enu[..., 0] / eph) == pytest.approx(1.0, abs=0.05)
    assert np.std(enu[..., 1] / eph) == pytest.approx(1.0, abs=0.05)
    assert np.std(enu[..., 2] / epv) == pytest.approx(1.0, abs=0.05)
    sats = np.stack([s.satellites for s in samples])
    hdop = PARAMS.hdop_reference * np.sqrt((PARAMS.satellites_reference - 2) / (sats - 2))
    assert eph == pytest.approx(hdop * PARAMS.uere_m / np.sqrt(2.0))
    # Fewer satellites, larger reported and actual error.
    few = sats <= np.percentile(sats, 20)
    many = sats >= np.percentile(sats, 80)
    assert eph[few].mean() > eph[many].mean()
    assert np.abs(enu[..., 0][few]).mean() > np.abs(enu[..., 0][many]).mean()


NEO_M9N_CEP50_M = 1.5
"""u-blox NEO-M9N data sheet UBX-19014285, table of performance in GNSS modes: horizontal PVT
position accuracy 1.5 m CEP (50 %, 24 hours static, -130 dBm, > 6 satellites). The Typhoon
H480's receiver class (its YAML's gps.receiver)."""
CEP50_PER_SIGMA = 1.1774
"""CEP50 of a circular Gaussian over its per-axis standard deviation, sqrt(2 ln 2)."""


def test_horizontal_error_matches_the_receivers_datasheet():
    """400 receivers held still for an hour, sampled every 30 s (the error wanders with a 60 s
    correlation time): the radius holding half the horizontal errors is the datasheet's CEP50,
    the per-axis spread its CEP50 / 1.1774, and the reported eph agrees with the actual spread.

    Bounds (seeds 9-11 give CEP50 1.504-1.512 m, per-axis sigma +1.1 to +2.0 % above 1.274 m,
    RMS eph within 0.4 % of the measured spread): CEP50 within 1.2 %, per-axis sigma within 3 %
    (the satellite count wanders around its reference, so the RMS of HDOP sits ~1.4 % above the
    reference's), RMS eph within 1 % of the measured per-axis spread.
    """
    gps = _receivers(400, seed=9, common_error_fraction=0.0)  # independent: see above
    samples = _run_still(gps, 3600, dt_s=1.0)[::30]
    enu = np.stack(
        [frames.geodetic_to_enu(s.lat_deg, s.lon_deg, s.alt_amsl_m, ORIGIN) for s in samples]
    )
    radius = np.hypot(enu[..., 0], enu[..., 1])
    assert np.median(radius) == pytest.approx(NEO_M9N_CEP50_M, rel=0.012)
    sigma = NEO_M9N_CEP50_M / CEP50_PER_SIGMA
    per_axis = enu[..., :2].std(axis=(0, 1))
    assert per_axis == pytest.approx([sigma, sigma], rel=0.03)
    eph = np.stack([s.eph_m for s in samples])
    assert np.sqrt(np.mean(eph**2)) == pytest.approx(per_axis.mean(), rel=0.01)
    print(f"NEO-M9N: CEP50 {np.median(radius):.3f} m (datasheet {NEO_M9N_CEP50_M}), per-axis "
          f"sigma {per_axis.round(3)} m (datasheet / 1.1774 = {sigma:.3f}), "
          f"RMS eph {np.sqrt(np.mean(eph**2)):.3f} m")  # fmt: skip


def test_receivers_of_one_world_err_together():
    """Two receivers side by side share common_error_fraction c of their wandering error, so
    neighbouring vehicles do not see each other metres off: over 100 independent pairs held
    still for an hour, the spread of their difference per axis is what c predicts from the
    accuracies they report, c (w1 - w2)² + (1 - c)(w1² + w2²) + 2 white² with w the wandering
    part of eph (0.62 m for the NEO-M9N's 1.27 m per axis, where independent receivers would
    differ by 1.8 m), and their errors correlate as c w1 w2 / (eph1 eph2) predicts. Bounds:
    the difference within 5 % (achieved 0.5-0.8 %), the correlation within 0.02 (achieved
    0.003)."""
    c = PARAMS.common_error_fraction
    white = PARAMS.horizontal_noise_sigma_m
    errors, ephs = [], []
    for pair in range(100):
        gps = _receivers(2, seed=1000 + pair)
        for s in _run_still(gps, 120, dt_s=30.0):  # an hour, every 30 s (exact discretisation)
            errors.append(frames.geodetic_to_enu(s.lat_deg, s.lon_deg, s.alt_amsl_m, ORIGIN)[:, :2])
            ephs.append(s.eph_m)
    e, eph = np.array(errors), np.array(ephs)  # (samples, receiver, axis), (samples, receiver)
    w = np.sqrt(eph**2 - white**2)
    predicted_var = (
        np.mean(c * (w[:, 0] - w[:, 1]) ** 2 + (1 - c) * (w**2).sum(axis=1)) + 2 * white**2
    )
    difference = (e[:, 0, :] - e[:, 1, :]).std()
    corr = np.mean([np.corrcoef(e[:, 0, k], e[:, 1, k])[0, 1] for k in range(2)])
    predicted_corr = c * np.mean(w[:, 0] * w[:, 1]) / np.sqrt(np.prod(np.mean(eph**2, axis=0)))
    print(f"difference {difference:.3f} m (predicted {np.sqrt(predicted_var):.3f}), "
          f"correlation {corr:.3f} (predicted {predicted_corr:.3f})")  # fmt: skip
    assert difference == pytest.approx(np.sqrt(predicted_var), rel=0.05)
    assert corr == pytest.approx(predicted_corr, abs=0.02)


def test_a_world_hands_every_airframe_group_the_same_common_error():
    from sitl.world import World, WorldConfig

    world = World(WorldConfig(n_vehicles=2, airframe=("typhoon_h480", "x500"), seed=4))
    try:
        a, b = (group.gps.shared_error for group in world._groups)
        assert a is b
    finally:
        world.close()


def test_satellites_wander_slowly_around_their_mean():
    """Counts vary (not a constant), stay in [0, max], average the mean, change over minutes."""
    gps = _receivers(100, seed=6)
    sats = np.stack([s.satellites for s in _run_still(gps, 3600, dt_s=1.0)])  # 1 h at 1 Hz
    assert sats.mean() == pytest.approx(PARAMS.satellites_mean, abs=0.5)
    assert sats.std() == pytest.approx(PARAMS.satellites_sigma, rel=0.2)
    assert sats.min() >= 0 and sats.max() <= PARAMS.satellites_max
    changes_per_min = np.mean(sats[1:] != sats[:-1]) * 60.0
    assert 0.1 < changes_per_min < 10.0


@pytest.mark.parametrize(("mean", "fix"), [(2.0, FIX_NONE), (3.0, FIX_2D), (9.0, FIX_3D)])
def test_fix_type_follows_the_satellite_count(mean, fix):
    """0-2 satellites: no fix; 3: 2D fix; 4 or more: 3D fix."""
    gps = _receivers(3, satellites_mean=mean, satellites_sigma=0.0)
    sample = _run_still(gps, 2)[-1]
    assert np.all(sample.fix_type == fix)
    assert np.all(sample.satellites == int(mean))


def test_gps_draws_do_not_shift_other_sensors():
    """Switching random GPS outages on changes the GPS messages, not the IMU's noise."""

    def run(outages: GpsOutages) -> tuple[list, list]:
        world = make_world(seed=7, gps_outages=outages)
        sensors, gps = collect(world, 2.0)
        world.close()
        return [m[0].xacc for m in sensors], [m[0].lat for m in gps]

    imu_a, gps_a = run(GpsOutages())
    imu_b, gps_b = run(GpsOutages(mean_interval_s=0.5, mean_duration_s=0.5))
    assert imu_a == imu_b
    assert gps_a != gps_b


def test_no_fix_message_packs_with_unknown_accuracy():
    """HIL_GPS without a fix: fix_type 1, 0 satellites, eph/epv 65535, packs as MAVLink 2."""
    msg = hil.hil_gps_messages(5_000_000, GpsSample.no_fix(1, 5.0))[0]
    mav = mavlink2.MAVLink(None)
    decoded = mav.decode(bytearray(msg.pack(mav)))
    assert (decoded.fix_type, decoded.satellites_visible) == (1, 0)
    assert (decoded.eph, decoded.epv, decoded.time_usec) == (65535, 65535, 5_000_000)


def test_receivers_of_a_group_of_vehicles_name_world_indices():
    """Receivers for world rows 2 and 3 (an airframe group): poll reads those rows, a window for
    vehicle 3 silences only the second receiver; measured 60 steps (120 ms) before each send."""
    rng = np.random.default_rng(8)
    outages = GpsOutages(windows=((0.0, 100.0, 3),))
    gps = Gps(PARAMS, ORIGIN, 2, rng, outages, physics_hz=500.0, gps_hz=10.0, rows=slice(2, 4))
    assert gps.vehicle_ids.tolist() == [2, 3] and gps.delay_ticks == 60
    world_enu = np.array([[0.0, 0.0, 0.0]] * 2 + [[100.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    sent = [gps.poll(tick, world_enu, np.zeros((4, 3))) for tick in range(0, 201)]
    sends = [(tick, fix) for tick, fix in enumerate(sent) if fix is not None]
    assert [tick for tick, _ in sends] == [0, 50, 100, 150, 200]
    assert [fix.time_s for _, fix in sends] == pytest.approx([0.0, 0.1, 0.08, 0.18, 0.28])
    last = sends[-1][1]
    assert last.fix_type.tolist() == [FIX_3D, FIX_NONE]
    east = frames.geodetic_to_enu(last.lat_deg[0], last.lon_deg[0], last.alt_amsl_m[0], ORIGIN)
    assert east[0] == pytest.approx(100.0, abs=3.0)
