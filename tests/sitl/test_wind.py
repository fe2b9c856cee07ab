"""Wind: the Dryden statistics, gusts, determinism, and the drag it exerts on a vehicle.

The statistics tests run the wind model alone (no physics) for many vehicles at once; the
expectations are MIL-F-8785C's low-altitude formulas and the Dryden autocorrelations, computed
here independently of the model's filter.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sitl_test_helpers import actuator_message, make_world, run

from sitl.physics.wind import TURBULENCE_W20_M_S, WindConfig, WindField

FT = 0.3048


def _run_field(
    config: WindConfig, height_m: float, n: int, steps: int, dt_s: float = 0.01, seed: int = 1
) -> np.ndarray:
    """Wind (steps, n, 3) at n vehicles hovering still at height_m."""
    field = WindField(config, n, dt_s, np.random.default_rng(seed))
    pos = np.zeros((n, 3))
    pos[:, 2] = height_m
    vel = np.zeros((n, 3))
    out = np.empty((steps, n, 3))
    for k in range(steps):
        out[k] = field.update(pos, vel)
    return out


def _expected_dryden(height_m: float, w20: float) -> tuple[np.ndarray, np.ndarray]:
    """MIL-F-8785C low altitude: (sigma_u, sigma_v, sigma_w), (L_u, L_v, L_w) in SI."""
    h = height_m / FT
    sigma_w = 0.1 * w20
    sigma_u = sigma_w / (0.177 + 0.000823 * h) ** 0.4
    length_u = h / (0.177 + 0.000823 * h) ** 1.2 * FT
    return np.array([sigma_u, sigma_u, sigma_w]), np.array([length_u, length_u, height_m])


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("speed_m_s", -1.0),
        ("from_deg", 360.0),
        ("up_m_s", math.nan),
        ("turbulence_w20_m_s", -0.1),
        ("gust_peak_m_s", -2.0),
        ("gust_length_m", 0.0),
        ("gust_interval_s", -5.0),
        ("min_airspeed_m_s", 0.0),
        ("update_hz", 0.0),
    ],
)
def test_config_rejects_bad_values_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        WindConfig(**{field: value})


def test_world_rejects_wind_rate_not_dividing_physics():
    with pytest.raises(ValueError, match="update_hz"):
        make_world(wind=WindConfig(update_hz=300.0))


def test_steady_wind_blows_from_the_meteorological_direction():
    """5@270 is a west wind: the air moves east; from 0 deg the air moves south."""
    np.testing.assert_allclose(WindConfig(5.0, 270.0).steady_enu_m_s, [5.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(WindConfig(5.0, 0.0).steady_enu_m_s, [0.0, -5.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(
        WindConfig(2.0, 45.0, up_m_s=0.5).steady_enu_m_s,
        [-math.sqrt(2.0), -math.sqrt(2.0), 0.5],
        atol=1e-12,
    )


@pytest.mark.parametrize("height_m", [10.0, 60.0])
def test_dryden_sigma_and_correlation_match_mil_f_8785c(height_m):
    """Per-axis RMS within 15 % of sigma; autocorrelation at one and two T = L / V as Dryden's.

    Dryden autocorrelations (distance xi = V tau): longitudinal exp(-xi / L); lateral and
    vertical (1 - xi / (2 L)) exp(-xi / L), i.e. e^-1 = 0.37 and 0.5 e^-1 = 0.18 at xi = L and
    0 at xi = 2 L.
    """
    wind_m_s = 8.0
    w20 = TURBULENCE_W20_M_S["moderate"]
    config = WindConfig(speed_m_s=wind_m_s, from_deg=270.0, turbulence_w20_m_s=w20)
    dt = 0.05
    sigma, length = _expected_dryden(height_m, w20)
    t_corr = length / wind_m_s  # s, per axis
    steps = int(4 * t_corr.max() / dt)
    wind = _run_field(config, height_m, n=600, steps=steps, dt_s=dt)
    # Mean-wind axes: u along the air's motion (east here), v north (its left), w up.
    turb = wind - config.steady_enu_m_s
    rms = np.sqrt(np.mean(turb**2, axis=(0, 1)))
    np.testing.assert_allclose(rms, sigma, rtol=0.15)
    for axis in range(3):
        x = turb[:, :, axis] / sigma[axis]
        for xi_over_l, lateral_expect, longitudinal_expect in (
            (1.0, 0.5 * math.exp(-1.0), math.exp(-1.0)),
            (2.0, 0.0, math.exp(-2.0)),
        ):
            lag = round(xi_over_l * t_corr[axis] / dt)
            rho = float(np.mean(x[:-lag] * x[lag:]))
            expect = longitudinal_expect if axis == 0 else lateral_expect
            assert abs(rho - expect) < 0.08, (axis, xi_over_l, rho, expect)


def test_turbulence_is_weaker_and_slower_with_lighter_intensity_and_faster_when_flying():
    """Light turbulence has half the RMS of moderate (sigma proportional to W20); crossing the
    field at twice the speed halves the correlation time."""
    n, steps, dt = 400, 400, 0.02
    light = WindConfig(turbulence_w20_m_s=TURBULENCE_W20_M_S["light"], min_airspeed_m_s=4.0)
    moderate = WindConfig(turbulence_w20_m_s=TURBULENCE_W20_M_S["moderate"], min_airspeed_m_s=4.0)
    rms_light = np.std(_run_field(light, 20.0, n, steps, dt)[..., 2])
    rms_moderate = np.std(_run_field(moderate, 20.0, n, steps, dt)[..., 2])
    assert rms_light / rms_moderate == pytest.approx(0.5, rel=0.1)

    def vertical_correlation_at(lag_s: float, vehicle_speed_m_s: float) -> float:
        field = WindField(light, n, dt, np.random.default_rng(5))
        pos = np.zeros((n, 3))
        pos[:, 2] = 20.0
        vel = np.zeros((n, 3))
        vel[:, 1] = vehicle_speed_m_s
        w = np.array([field.update(pos, vel)[:, 2].copy() for _ in range(steps)])
        lag = round(lag_s / dt)
        return float(np.mean(w[:-lag] * w[lag:]) / np.mean(w * w))

    # L_w = 20 m: at 4 m/s T = 5 s, at 8 m/s T = 2.5 s; lag 2.5 s is xi = L/2 resp. L.
    assert vertical_correlation_at(2.5, 4.0) > 0.4  # 0.75 e^-0.5 = 0.45
    assert vertical_correlation_at(2.5, 8.0) < 0.26  # 0.5 e^-1 = 0.18


def test_same_seed_same_wind_other_seed_other_wind_each_vehicle_its_own():
    config = WindConfig(
        speed_m_s=6.0,
        from_deg=90.0,
        turbulence_w20_m_s=TURBULENCE_W20_M_S["light"],
        gust_peak_m_s=3.0,
        gust_interval_s=2.0,
    )
    a = _run_field(config, 15.0, n=3, steps=500, seed=7)
    b = _run_field(config, 15.0, n=3, steps=500, seed=7)
    c = _run_field(config, 15.0, n=3, steps=500, seed=8)
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)
    assert not np.allclose(a[:, 0], a[:, 1])


def test_gusts_have_the_1_cosine_shape_peak_length_and_rate():
    """Each gust rises to the peak over d_m and falls back over d_m (crossed at the wind speed),
    along the mean wind; onsets come at the configured mean interval."""
    wind_m_s, peak, length, interval = 5.0, 3.0, 10.0, 4.0
    config = WindConfig(
        speed_m_s=wind_m_s,
        from_deg=180.0,  # south wind: blows north
        gust_peak_m_s=peak,
        gust_length_m=length,
        gust_interval_s=interval,
    )
    dt, n, duration = 0.02, 200, 200.0
    wind = _run_field(config, 30.0, n=n, steps=round(duration / dt), dt_s=dt)
    gust = wind - config.steady_enu_m_s
    np.testing.assert_allclose(gust[..., [0, 2]], 0.0, atol=1e-12)  # along the wind only
    north = gust[..., 1]
    assert north.min() >= 0.0 and north.max() <= peak + 1e-12
    # Onsets: the gust wind leaves zero. Poisson rate n * duration / interval (+- 4 sigma).
    onsets = np.count_nonzero((north[1:] > 0.0) & (north[:-1] == 0.0))
    expected = n * duration / interval
    assert abs(onsets - expected) < 4.0 * math.sqrt(expected)
    # An isolated gust at vehicle 0: 1-cosine over 2 d_m / V seconds, reaching the peak.
    v0 = north[:, 0]
    start = int(np.flatnonzero(v0 > 0.0)[0]) - 1
    t = np.arange(round(2 * length / wind_m_s / dt) + 1) * dt
    shape = 0.5 * peak * (1.0 - np.cos(np.pi * wind_m_s * t / length))
    segment = v0[start : start + len(t)]
    if np.all(segment[1:-1] > 0.0):  # not overlapped by the next gust
        np.testing.assert_allclose(segment, shape, atol=1e-9)
    assert north.max() == pytest.approx(peak, rel=1e-3)


def test_calm_wind_config_changes_nothing_and_keeps_the_sensor_draws():
    """A world with an all-zero WindConfig is bit-identical to one without wind (the wind's
    generator is a child spawned after the sensors), including every sensor message."""
    hover = [actuator_message([0.6] * 6)]
    out = []
    for wind in (None, WindConfig()):
        with make_world(wind=wind, spawn_altitude_m=20.0, seed=4) as world:
            msgs = []
            for _ in range(200):
                world.step(hover)
                s, _ = world.poll_sensors()
                if s is not None:
                    msgs.append((s[0].xacc, s[0].yacc, s[0].zgyro, s[0].abs_pressure))
            out.append((msgs, world.truth.position_enu_m, world.truth.velocity_enu_m_s))
    assert out[0][0] == out[1][0]
    assert np.array_equal(out[0][1], out[1][1]) and np.array_equal(out[0][2], out[1][2])


def test_turbulent_wind_keeps_the_first_sensor_draws():
    """Sensor noise does not depend on whether there is wind (same first HIL_SENSOR)."""
    first = []
    for wind in (None, WindConfig(8.0, 270.0, turbulence_w20_m_s=10.0, gust_peak_m_s=2.0)):
        with make_world(wind=wind, seed=9) as world:
            s, g = world.poll_sensors()
            first.append(([m.get_payload() for m in s], [m.get_payload() for m in g]))
    assert first[0] == first[1]


def test_falling_bodies_are_carried_by_the_wind_as_the_parasite_drag_predicts():
    """Motors off, spawned level at 100 m in a steady 8 m/s west wind, a Typhoon and an x500
    (two airframe groups): the only horizontal force is the quadratic parasite drag
    k (w - v)^2 (k = 1/2 rho (Cd A)_x), so the airspeed decays as u(t) = w / (1 + k w t / m):
    v_east(t) = w - u(t), and v_north = 0."""
    wind = 8.0
    with make_world(
        n_vehicles=2,
        airframe=("typhoon_h480", "x500"),
        wind=WindConfig(wind, 270.0),
        spawn_altitude_m=100.0,
    ) as world:
        run(world, 2.0, [actuator_message([0.0] * 6, armed=False)] * 2)
        truth = world.truth
        for i, spec in enumerate(world.airframes):
            k = spec.fuselage.coefficients_n_s2_m2()[0]
            expected = wind - wind / (1.0 + k * wind * truth.time_s / spec.mass_kg)
            assert truth.velocity_enu_m_s[i, 0] == pytest.approx(expected, rel=0.02), spec.name
            assert abs(truth.velocity_enu_m_s[i, 1]) < 1e-3 * expected
            np.testing.assert_allclose(truth.wind_enu_m_s[i], [wind, 0.0, 0.0], atol=1e-12)


def test_rotors_at_rest_in_wind_feel_the_rotor_drag_of_the_airspeed():
    """Rotors at hover speed, body at rest in a 6 m/s south wind (blowing north): the first
    step accelerates it north by (c_d sum_i w_i * 6 + k_y 6^2) / m, the drag model's closed
    form with the airspeed (relative velocity) in place of the velocity."""
    wind = 6.0
    with make_world(wind=WindConfig(wind, 180.0), spawn_altitude_m=50.0) as world:
        spec = world.airframe
        hover = [actuator_message([spec.hover_command] * len(spec.rotors))]
        world._groups[0].rotors.speed_rad_s[:] = spec.hover_command * spec.motor.max_speed_rad_s
        speeds = world.truth.rotor_speed_rad_s[0]
        world.step(hover)
        accel = world.truth.velocity_enu_m_s[0] * world.config.physics_hz
        force = speeds.sum() * spec.motor.rotor_drag_coefficient_n_s_m_rad * wind
        force += spec.fuselage.coefficients_n_s2_m2()[1] * wind**2
        assert accel[1] == pytest.approx(force / spec.mass_kg, rel=1e-3)
        assert abs(accel[0]) < 1e-3 * accel[1]
