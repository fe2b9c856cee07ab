"""Rigid-body and rotor physics of the Typhoon H480, checked against physics (never wall time)."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from sitl_test_helpers import actuator_message, make_world, run

from sitl.physics.earth import GRAVITY_M_S2


@pytest.fixture
def hover_world():
    world = make_world(spawn_altitude_m=10.0)
    yield world
    world.close()


def hover_u(world) -> float:
    spec = world.airframe
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    w_hover = np.sqrt(spec.mass_kg * GRAVITY_M_S2 / (6 * k_f))
    return float(w_hover / spec.motor.max_speed_rad_s)


def test_hover_thrust_equals_weight(hover_world):
    """At u = w_hover / w_max the vertical velocity stays constant and the body barely turns."""
    world = hover_world
    u = hover_u(world)
    assert u == pytest.approx(world.airframe.hover_command)
    command = [actuator_message([u] * 6)]
    run(world, 0.3, command)  # motors settle (time constants 12.5 / 25 ms)
    assert world.truth.rotor_speed_rad_s == pytest.approx(u * 1500.0, rel=1e-6)
    v0 = world.truth.velocity_enu_m_s[0, 2]
    run(world, 1.0, command)
    truth = world.truth
    assert abs(truth.velocity_enu_m_s[0, 2] - v0) < 0.05
    rates = truth.angular_velocity_body_frd_rad_s[0]
    # PX4's layout is not perfectly balanced (rotor x positions sum to +0.24 mm), which with the
    # rotor drag at the hubs rocks the body slowly in pitch; nothing else turns it.
    assert abs(rates[2]) < 1e-4
    assert abs(rates[0]) < 0.02
    assert np.linalg.norm(rates) < 0.15
    assert truth.tilt_rad[0] < 0.05


def test_free_fall_with_motors_off(hover_world):
    """Disarmed from 20 m: z(1 s) = 20 - g/2 within 1 %, and the accelerometer reads ~0."""
    world = make_world(spawn_altitude_m=20.0)
    disarmed = [actuator_message([1.0] * 6, armed=False)]
    accel_z = []
    for _ in range(500):
        world.step(disarmed)
        sensors, _ = world.poll_sensors()
        if sensors:
            accel_z.append(sensors[0].zacc)
    z = world.truth.position_enu_m[0, 2]
    assert z == pytest.approx(20.0 - 0.5 * GRAVITY_M_S2, rel=0.01)
    assert np.all(world.truth.rotor_speed_rad_s == 0.0)
    assert abs(np.mean(accel_z[1:])) < 0.2  # only the small fuselage drag
    world.close()


def test_at_rest_on_the_ground_stays_put():
    """Spawned on its skids, the vehicle does not drift by 1 cm in 5 s."""
    world = make_world()
    start = world.truth.position_enu_m.copy()
    assert start[0, 2] == pytest.approx(world.airframe.ground_clearance_m)
    run(world, 5.0)
    assert np.linalg.norm(world.truth.position_enu_m - start) < 0.01
    assert world.truth.tilt_rad[0] < 1e-3
    world.close()


def _torque_response(world, u_per_output, axis, torque_of_speeds):
    """Body FRD rate about ``axis`` after 0.1 s of a differential command, and the rate that the
    rotor torque (from the true rotor speeds of every step) predicts for a rigid body at rest."""
    u = world.airframe.hover_command
    run(world, 0.3, [actuator_message([u] * 6)])  # rotors at hover speed
    rate0 = world.truth.angular_velocity_body_frd_rad_s[0, axis]
    inertia = world.airframe.inertia_diag_kg_m2[axis]
    command = [actuator_message(u_per_output)]
    predicted = rate0
    for _ in range(50):
        predicted += torque_of_speeds(world.truth.rotor_speed_rad_s[0]) / inertia / 500.0
        world.step(command)
    return world.truth.angular_velocity_body_frd_rad_s[0, axis], predicted


def test_ccw_rotors_faster_yaw_clockwise(hover_world):
    """Faster CCW rotors yaw the body clockwise seen from above: positive FRD yaw rate."""
    world = hover_world
    u = hover_u(world)
    spec = world.airframe
    sign = np.array([1.0 if r.spin.value == "ccw" else -1.0 for r in spec.rotors])
    k_m = spec.motor.moment_coefficient_m * spec.motor.thrust_coefficient_n_s2_rad2
    rate, predicted = _torque_response(
        world, list(u + 0.05 * sign), 2, lambda w: k_m * float(sign @ w**2)
    )
    assert predicted > 0.1
    assert rate == pytest.approx(predicted, rel=0.05)


def test_more_thrust_on_the_left_rolls_right(hover_world):
    """More thrust on the left rotors (FRD y < 0) rolls the body right: positive FRD roll."""
    world = hover_world
    u = hover_u(world)
    spec = world.airframe
    y = np.array([r.position_frd_m[1] for r in spec.rotors])
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    # Thrust -T along FRD z at (x, y, z): torque about x is y * (-T).
    rate, predicted = _torque_response(
        world, list(u + 0.01 * (y < 0)), 0, lambda w: float(-y @ (k_f * w**2))
    )
    assert predicted > 0.1
    assert rate == pytest.approx(predicted, rel=0.05)
    assert world.truth.euler_ned_frd_rad[0, 0] > 0.0


def test_motor_lag_time_constants(hover_world):
    """A step command is followed exactly as exp(-t / tau): tau up 12.5 ms, down 25 ms."""
    world = hover_world
    motor = world.airframe.motor
    dt = 1.0 / world.config.physics_hz
    run(world, 10 * dt, [actuator_message([0.5] * 6)])
    rise = 1.0 - np.exp(-10 * dt / motor.time_constant_up_s)
    assert world.truth.rotor_speed_rad_s[0, 0] == pytest.approx(750.0 * rise, rel=1e-9)
    run(world, 0.5, [None])  # None keeps the command
    assert world.truth.rotor_speed_rad_s[0, 0] == pytest.approx(750.0, rel=1e-6)
    run(world, 10 * dt, [actuator_message([0.0] * 6)])
    fall = np.exp(-10 * dt / motor.time_constant_down_s)
    assert world.truth.rotor_speed_rad_s[0, 0] == pytest.approx(750.0 * fall, rel=1e-6)


def test_commands_are_clipped_and_nan_is_zero(hover_world, caplog):
    """u > 1 runs at max speed, u < 0 and NaN at zero; NaN is logged once."""
    world = hover_world
    with caplog.at_level(logging.WARNING, logger="sitl.world"):
        command = [actuator_message([2.0, -1.0, float("nan"), 1.0, 0.0, float("nan")])]
        run(world, 0.5, command)
    speeds = world.truth.rotor_speed_rad_s[0]
    assert speeds == pytest.approx([1500.0, 0.0, 0.0, 1500.0, 0.0, 0.0], abs=1e-3)
    assert sum("NaN" in r.message for r in caplog.records) == 1


def test_disarmed_commands_zero_and_electrical_power(hover_world):
    """Without SAFETY_ARMED the rotors spin down; the electrical power is the momentum-theory
    power of the thrust k_f w^2 of each rotor (sitl.power.propulsion) plus the loads."""
    world = hover_world
    run(world, 0.3, [actuator_message([0.5] * 6)])
    truth = world.truth
    spec = world.airframe
    power = world.power
    thrust = spec.motor.thrust_coefficient_n_s2_rad2 * 750.0**2
    expected = power.spec.propulsion.hover_power_w([thrust] * 6, power.air_density_kg_m3)
    assert truth.electrical_power_w[0] == pytest.approx(expected + power.loads_w[0], rel=1e-6)
    run(world, 1.0, [actuator_message([0.5] * 6, armed=False)])
    assert np.all(world.truth.rotor_speed_rad_s < 1.0)


def test_rotor_drag_opposes_horizontal_motion():
    """Spinning rotors brake a sideways drift: F = -c sum(w) v in the rotor plane."""
    world = make_world(spawn_altitude_m=50.0)
    u = hover_u(world)
    run(world, 0.3, [actuator_message([u] * 6)])
    rotors = world._rotors
    wrench = rotors.body_wrench(np.array([[[1.0, 0.0, 0.0]]])).copy()  # 1 m/s forward (FLU)
    c = world.airframe.motor.rotor_drag_coefficient_n_s_m_rad
    expected = -c * rotors.speed_rad_s.sum() - world.airframe.fuselage_drag_n_s_m[0]
    assert wrench[0, 0] == pytest.approx(expected, rel=1e-9)
    assert wrench[0, 4] < 0.0  # drag at hubs above the CoM pitches the nose up (FLU -y)
    world.close()


def test_fleet_spawns_apart_facing_north():
    """Vehicle i spawns at (i * spacing, 0) facing north; homes are their geodetic spawn points."""
    world = make_world(n_vehicles=3, spacing_m=4.0)
    truth = world.truth
    assert truth.position_enu_m[:, 0] == pytest.approx([0.0, 4.0, 8.0])
    assert truth.euler_ned_frd_rad[:, 2] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    lat, lon, alt = world.home_geodetic(2)
    assert lon > world.config.origin_lon_deg and lat == pytest.approx(world.config.origin_lat_deg)
    assert alt == pytest.approx(488.0 + world.airframe.ground_clearance_m)
    assert truth.rotor_speed_rad_s.shape == (3, 6)
    assert truth.lat_deg.shape == (3,)
    world.close()


def test_fleet_vehicles_move_as_if_alone():
    """Vectorisation: each vehicle of a fleet moves exactly as the same vehicle alone."""
    u = 0.48
    commands = [actuator_message([u + 0.02, u, u, u - 0.01, u, u]), actuator_message([u] * 6)]
    fleet = make_world(n_vehicles=2, spacing_m=20.0, spawn_altitude_m=10.0)
    run(fleet, 0.5, commands)
    for i, command in enumerate(commands):
        alone = make_world(spawn_altitude_m=10.0)
        run(alone, 0.5, [command])
        offset = np.array([20.0 * i, 0.0, 0.0])
        assert fleet.truth.position_enu_m[i] - offset == pytest.approx(
            alone.truth.position_enu_m[0], abs=1e-9
        )
        assert fleet.truth.angular_velocity_body_frd_rad_s[i] == pytest.approx(
            alone.truth.angular_velocity_body_frd_rad_s[0], abs=1e-9
        )
        alone.close()
    fleet.close()
