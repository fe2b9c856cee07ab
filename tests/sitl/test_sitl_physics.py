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


def test_free_fall_with_motors_off(hover_world):
    """Disarmed from 20 m, level: the fall follows the closed form of a body with quadratic drag
    ``z(t) = z0 - (m / k) ln cosh(t sqrt(g k / m))``, ``k = 1/2 rho (Cd A)_z``, and the
    accelerometer reads the drag alone (specific force ``-k v^2 / m`` along FRD z)."""
    world = make_world(spawn_altitude_m=20.0)
    spec = world.airframe
    k = spec.fuselage.coefficients_n_s2_m2()[2]
    m = spec.mass_kg
    disarmed = [actuator_message([1.0] * 6, armed=False)]
    accel_z, drag_accel = [], []
    for _ in range(500):
        world.step(disarmed)
        sensors, _ = world.poll_sensors()
        if sensors:
            accel_z.append(sensors[0].zacc)
            drag_accel.append(-k * world.truth.velocity_enu_m_s[0, 2] ** 2 / m)
    t = 1.0
    rate = np.sqrt(GRAVITY_M_S2 * k / m)
    z = 20.0 - m / k * np.log(np.cosh(rate * t))
    v = np.sqrt(m * GRAVITY_M_S2 / k) * np.tanh(rate * t)
    truth = world.truth
    assert truth.position_enu_m[0, 2] == pytest.approx(z, abs=0.01)
    assert truth.velocity_enu_m_s[0, 2] == pytest.approx(-v, abs=0.01)
    # The drag is what tells this from a vacuum fall (20 - g/2 = 15.095 m).
    assert truth.position_enu_m[0, 2] - (20.0 - 0.5 * GRAVITY_M_S2) > 0.1
    assert np.all(truth.rotor_speed_rad_s == 0.0)
    # The accelerometer reads the drag deceleration plus its own bias (full turn-on bias).
    noise = world._groups[0].imu.noise
    bias_z = float(noise.turn_on_bias[0][0, 2] + noise.bias[0][0, 2])
    assert np.mean(accel_z[-25:]) - bias_z == pytest.approx(np.mean(drag_accel[-25:]), abs=0.05)
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
    """Spinning rotors brake a sideways drift: F = -c sum(w) v - 1/2 rho CdA v|v| in the plane."""
    world = make_world(spawn_altitude_m=50.0)
    u = hover_u(world)
    run(world, 0.3, [actuator_message([u] * 6)])
    rotors = world._groups[0].rotors
    spec = world.airframe
    c = spec.motor.rotor_drag_coefficient_n_s_m_rad
    kx, _, kz = spec.fuselage.coefficients_n_s2_m2()
    for v in (1.0, -3.0):
        wrench = rotors.body_wrench(np.array([[[v, 0.0, 0.0]]])).copy()  # forward (FLU)
        expected = -c * rotors.speed_rad_s.sum() * v - kx * v * abs(v)
        assert wrench[0, 0] == pytest.approx(expected, rel=1e-9)
        assert wrench[0, 2] == pytest.approx(
            rotors.speed_rad_s[0]
            @ rotors.speed_rad_s[0]
            * (spec.motor.thrust_coefficient_n_s2_rad2),
            rel=1e-9,
        )  # no vertical drag from a horizontal velocity
        # drag at hubs above the CoM pitches the nose up (FLU -y) when flying forward
        assert np.sign(wrench[0, 4]) == -np.sign(v)
    climb = rotors.body_wrench(np.array([[[0.0, 0.0, 2.0]]])).copy()
    thrust = spec.motor.thrust_coefficient_n_s2_rad2 * float(
        rotors.speed_rad_s[0] @ rotors.speed_rad_s[0]
    )
    assert climb[0, 2] == pytest.approx(thrust - kz * 4.0, rel=1e-9)  # parasite drag only
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


def fly_level_at_fixed_tilt(world, tilt_rad: float, seconds: float) -> float:
    """Fly north with the attitude held at ``tilt_rad`` nose-down and return the final speed.

    The attitude is reset every step (rotations frozen, as an ideal attitude loop would); the equal
    rotor speeds come from a vertical position/velocity loop, so the vehicle settles into the level
    flight where only drag balances the horizontal thrust.
    """
    import pybullet as p

    from sitl import frames

    spec = world.airframe
    n = len(spec.rotors)
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    scene = world._scene
    body, cid = scene.body_ids[0], scene.client_id
    attitude = frames.quat_ned_frd_to_enu_flu(frames.quat_from_euler_ned_frd(0.0, -tilt_rad, 0.0))
    z0 = world.truth.position_enu_m[0, 2]
    for _ in range(round(seconds * world.config.physics_hz)):
        position, _ = p.getBasePositionAndOrientation(body, physicsClientId=cid)
        velocity, _ = p.getBaseVelocity(body, physicsClientId=cid)
        p.resetBasePositionAndOrientation(body, position, attitude.tolist(), physicsClientId=cid)
        p.resetBaseVelocity(body, velocity, [0.0, 0.0, 0.0], physicsClientId=cid)
        scene.read_state()
        accel = -4.0 * velocity[2] - 4.0 * (position[2] - z0)
        thrust = spec.mass_kg * (GRAVITY_M_S2 + accel) / np.cos(tilt_rad)
        u = np.sqrt(max(thrust, 0.0) / (n * k_f)) / spec.motor.max_speed_rad_s
        world.step([actuator_message([u] * n)])
    truth = world.truth
    assert abs(truth.velocity_enu_m_s[0, 2]) < 0.01  # level
    assert abs(truth.velocity_enu_m_s[0, 0]) < 1e-6  # straight north
    return float(truth.velocity_enu_m_s[0, 1])


def level_flight_closed_form(spec, tilt_rad: float):
    return spec.level_flight(tilt_rad)


@pytest.mark.parametrize(
    ("airframe", "tilt_deg"),
    [("typhoon_h480", 10.0), ("typhoon_h480", 20.0), ("typhoon_h480", 35.0), ("x500", 20.0)],
)
def test_level_flight_speed_matches_the_drag_closed_form(airframe, tilt_deg):
    """Held at a fixed tilt, the simulated vehicle settles at the closed-form level-flight speed."""
    world = make_world(airframe=airframe, spawn_altitude_m=100.0)
    tilt = np.radians(tilt_deg)
    speed = fly_level_at_fixed_tilt(world, tilt, 25.0)
    expected = level_flight_closed_form(world.airframe, tilt)
    assert speed == pytest.approx(expected.speed_m_s, rel=0.01)
    n = len(world.airframe.rotors)
    assert world.truth.rotor_speed_rad_s[0] == pytest.approx(
        [expected.rotor_speed_rad_s] * n, rel=0.01
    )
    world.close()


def test_typhoon_reaches_the_published_top_speed_at_35_degrees():
    """The identified drag: Yuneec's 70 km/h (19.4 m/s) at 35 deg of tilt; cruise 5 m/s < 10 deg."""
    from sitl.vehicles.multirotor import load_airframe

    spec = load_airframe("typhoon_h480")
    assert level_flight_closed_form(spec, np.radians(35.0)).speed_m_s == pytest.approx(
        19.4, rel=0.02
    )
    assert level_flight_closed_form(spec, np.radians(10.0)).speed_m_s > 5.0
    # PX4's MPC_XY_VEL_MAX (12 m/s) is reachable well inside MPC_TILTMAX_AIR (45 deg).
    assert level_flight_closed_form(spec, np.radians(25.0)).speed_m_s > 12.0
