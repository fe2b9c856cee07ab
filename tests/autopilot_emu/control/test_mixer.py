"""Allocation from CA_ROTOR* geometry produces the torques it is asked for, with the right signs.

The allocation is driven through the inner loop the fleet flies (``InnerLoop.step``), its rate
PID made to command exactly the torque under test: unit P gain, no I or D, no rate limit, the
torque given as an offboard body-rate setpoint at zero measured rate.
"""

import numpy as np
import pytest

from autopilot_emu.control.inner_loop import InnerLoop, InnerLoopGains
from autopilot_emu.control.mixer import (
    MAX_ROTORS,
    TYPHOON_H480_ROTORS,
    Mixer,
    RotorGeometry,
    normalised_mix,
)
from autopilot_emu.params import ParamStore

# PX4 Quad X output order: 1 front right CCW, 2 rear left CCW, 3 front left CW, 4 rear right CW.
QUAD_X = ((0.15, 0.15, 0.05), (-0.15, -0.15, 0.05), (0.15, -0.15, -0.05), (-0.15, 0.15, -0.05))


def mix(mixer: Mixer, torque: np.ndarray, thrust: np.ndarray) -> np.ndarray:
    """Motor outputs (N, MAX_ROTORS) of one inner-loop tick commanding ``torque`` (N, 3)."""
    n = len(thrust)
    zero, one = np.zeros((n, 3)), np.ones((n, 3))
    gains = InnerLoopGains(zero, np.full((n, 3), np.inf), one, zero, zero)
    loop = InnerLoop(gains, mixer)
    loop.step(
        q=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        rates_rad_s=np.zeros((n, 3)),
        q_sp=np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        thrust=np.asarray(thrust, dtype=float),
        overridden=np.ones(n, dtype=bool),
        rate_target_rad_s=np.asarray(torque, dtype=float),
        dt_s=0.004,
        active=np.ones(n, dtype=bool),
        armed=np.ones(n, dtype=bool),
    )
    return loop.state.outputs.copy()


def _wrench(outputs, rows=TYPHOON_H480_ROTORS):
    """Roll, pitch, yaw torque and thrust (per unit max rotor thrust) of motor outputs."""
    r = np.asarray(rows)
    t = outputs[: len(r)]  # THR_MDL_FAC 0 (PX4's default): the allocator's thrust = output
    return np.array([(-r[:, 1] * t).sum(), (r[:, 0] * t).sum(), (r[:, 2] * t).sum(), t.sum()])


def test_pure_thrust_is_symmetric():
    out = mix(Mixer(), np.zeros((1, 3)), np.array([0.4]))[0]
    np.testing.assert_allclose(out[:6], 0.4, rtol=2e-3)
    np.testing.assert_array_equal(out[6:], 0.0)
    np.testing.assert_allclose(_wrench(out)[:3], 0.0, atol=1e-12)


def test_each_axis_torque_has_the_commanded_sign_and_no_cross_coupling():
    mixer = Mixer()
    for axis in range(3):
        torque = np.zeros((1, 3))
        torque[0, axis] = 0.1
        w = _wrench(mix(mixer, torque, np.array([0.4]))[0])
        assert w[axis] > 0
        others = [k for k in range(3) if k != axis]
        assert np.all(np.abs(w[others]) < 1e-9)
        np.testing.assert_allclose(w[3], 6 * 0.4, rtol=1e-9)


def test_quad_x_torques_drive_the_motors_physics_asks_for():
    """Roll right: left motors up; pitch up: front motors up; yaw right: CCW motors up."""
    mixer = Mixer([RotorGeometry.from_rows(QUAD_X), RotorGeometry.from_rows(TYPHOON_H480_ROTORS)])
    np.testing.assert_array_equal(mixer.rotor_counts, [4, 6])
    hover = mix(mixer, np.zeros((2, 3)), np.full(2, 0.4))
    expect_up = {0: [1, 2], 1: [0, 2], 2: [0, 1]}
    for axis, up in expect_up.items():
        torque = np.zeros((2, 3))
        torque[:, axis] = 0.1
        out = mix(mixer, torque, np.full(2, 0.4))
        delta = out[0, :4] - hover[0, :4]
        down = [k for k in range(4) if k not in up]
        assert np.all(delta[up] > 0.01) and np.all(delta[down] < -0.01), (axis, delta)
        np.testing.assert_array_equal(out[0, 4:], 0.0)  # unused outputs stay off
        w = _wrench(out[0], QUAD_X)
        assert w[axis] > 0
        np.testing.assert_allclose(np.delete(w[:3], axis), 0.0, atol=1e-9)


def test_saturation_keeps_roll_and_pitch_and_outputs_in_range():
    mixer = Mixer([RotorGeometry.from_rows(TYPHOON_H480_ROTORS), RotorGeometry.from_rows(QUAD_X)])
    out = mix(mixer, np.array([[1.0, 0.0, 1.0], [1.0, 0.0, 1.0]]), np.array([0.9, 0.9]))
    assert np.all((out >= 0) & (out <= 1))
    assert _wrench(out[0])[0] > 0
    assert _wrench(out[1], QUAD_X)[0] > 0


def test_idle_output_when_no_thrust():
    mixer = Mixer([RotorGeometry.from_rows(QUAD_X)] * 2, idle_output=0.15)
    out = mix(mixer, np.zeros((2, 3)), np.zeros(2))
    np.testing.assert_allclose(out[:, :4], 0.15)
    np.testing.assert_array_equal(out[:, 4:], 0.0)
    assert out.shape == (2, MAX_ROTORS)


def test_geometry_from_params_defaults_to_the_typhoon_and_follows_changes():
    params = ParamStore()
    g = RotorGeometry.from_params(params)
    np.testing.assert_allclose(g.position_m, np.asarray(TYPHOON_H480_ROTORS)[:, :2], rtol=1e-6)
    np.testing.assert_allclose(g.moment_ratio_m, np.asarray(TYPHOON_H480_ROTORS)[:, 2], rtol=1e-6)
    params.set("CA_ROTOR_COUNT", 4)
    for i, (x, y, km) in enumerate(QUAD_X):
        params.set(f"CA_ROTOR{i}_PX", x)
        params.set(f"CA_ROTOR{i}_PY", y)
        params.set(f"CA_ROTOR{i}_KM", km)
    quad = RotorGeometry.from_params(params)
    np.testing.assert_allclose(quad.position_m, np.asarray(QUAD_X)[:, :2], rtol=1e-6)


def test_too_many_rotors_is_refused():
    with pytest.raises(ValueError, match="rotors"):
        RotorGeometry.from_rows(((0.1, 0.1, 0.05),) * (MAX_ROTORS + 1))


def test_fleet_builds_each_vehicles_mixer_from_its_params_and_rebuilds_on_change():
    """A hexa and a quad in one fleet: 6 and 4 motors driven, the other outputs 0."""
    from pymavlink.dialects.v20 import common as mavlink2

    from autopilot_emu.fleet import AutopilotFleet, FleetConfig

    params = [ParamStore(), ParamStore()]
    fleet = AutopilotFleet(FleetConfig(n_vehicles=2), params)

    def sensors(t_usec):
        msg = mavlink2.MAVLink_hil_sensor_message(
            t_usec, 0, 0, -9.80665, 0, 0, 0, 0.2, 0, 0.4, 1013.0, 0, 0, 488.0, 0, 0x1FFF
        )
        return [msg, msg]

    out = fleet.handle_sensors(sensors(4000))
    assert list(fleet.inner_loop.mixer.rotor_counts) == [6, 6]
    params[1].set("CA_ROTOR_COUNT", 4)
    for i, (x, y, km) in enumerate(QUAD_X):
        params[1].set(f"CA_ROTOR{i}_PX", x)
        params[1].set(f"CA_ROTOR{i}_PY", y)
        params[1].set(f"CA_ROTOR{i}_KM", km)
    fleet.commanders[0].armed = fleet.commanders[1].armed = True
    fleet.sync_commands(0)
    fleet.sync_commands(1)
    out = fleet.handle_sensors(sensors(8000))
    assert list(fleet.inner_loop.mixer.rotor_counts) == [6, 4]
    hexa, quad = (np.array(m.controls) for m in out)
    assert np.all(hexa[:6] > 0) and np.all(hexa[6:] == 0)  # armed idle on six motors
    assert np.all(quad[:4] > 0) and np.all(quad[4:] == 0)


def test_one_vehicles_saturation_leaves_the_others_outputs_alone():
    """Each vehicle is mixed alone (as each PX4 mixes its own): a saturated neighbour changes
    nothing in another vehicle's outputs.

    Vehicle 1 is inside 0..1 only thanks to its yaw torque (its roll/pitch part alone would go
    below 0 on a rotor): desaturating it, as the fleet-wide decision once did, would move it.
    """
    geometry = [RotorGeometry.from_rows(TYPHOON_H480_ROTORS)] * 2
    torque = np.array([[0.0, 0.0, 0.0], [-0.02497803, -0.03995277, -0.00233834]])
    thrust = np.array([0.4, 0.05115775])
    calm = mix(Mixer(geometry), torque, thrust)
    alone = mix(Mixer(geometry[:1]), torque[1:], thrust[1:])
    np.testing.assert_array_equal(alone[0], calm[1])
    torque[0], thrust[0] = (1.0, 0.0, 1.0), 0.95  # vehicle 0 saturates
    stormy = mix(Mixer(geometry), torque, thrust)
    np.testing.assert_array_equal(stormy[1], calm[1])


def test_px4_normalisation_of_the_hexa_x_and_quad_x():
    """PX4's ControlAllocationPseudoInverse scales, worked by hand for PX4's Hexa X layout
    (arm 1: rotors at y = ±1 and (±0.866, ±0.5)). The pseudo-inverse's roll column is y / Σy²
    = y / 3, pitch x / Σx² = x / 3. Roll scale sqrt((Σy² / 9) / (6 / 2)) = 1/3, pitch (4 rotors
    non-zero) sqrt((Σx² / 9) / (4 / 2)) = 0.408; both are divided by the larger, 0.408: roll
    entries ±0.816 and ±0.408, pitch ±0.707. A Quad X: ±0.707 on both. Yaw ±1, thrust 1."""
    hexa = ((0, 1, -0.05), (0, -1, 0.05), (0.866025, -0.5, -0.05), (-0.866025, 0.5, 0.05),
            (0.866025, 0.5, 0.05), (-0.866025, -0.5, -0.05))  # fmt: skip
    m = normalised_mix(RotorGeometry.from_rows(hexa))
    np.testing.assert_allclose(np.abs(m[:, 0]), [0.8165, 0.8165, 0.4082, 0.4082, 0.4082, 0.4082],
                               atol=1e-4)  # fmt: skip
    np.testing.assert_allclose(np.abs(m[:, 1]), [0, 0, 0.7071, 0.7071, 0.7071, 0.7071], atol=1e-4)
    np.testing.assert_allclose(np.abs(m[:, 2]), 1.0, atol=1e-9)
    np.testing.assert_allclose(m[:, 3], 1.0, atol=1e-9)
    quad = normalised_mix(RotorGeometry.from_rows(QUAD_X))
    np.testing.assert_allclose(np.abs(quad[:, :2]), 1 / np.sqrt(2), atol=1e-9)


@pytest.mark.parametrize(
    ("factor", "fraction", "output"),
    [
        (0.0, 0.5, 0.5),  # PX4 default: thrust linear in the output
        (1.0, 0.5, np.sqrt(0.5)),  # thrust = u²
        (0.5, 0.5, (np.sqrt(5.0) - 1.0) / 2.0),  # 0.5 u² + 0.5 u = 0.5
    ],
)
def test_thrust_model_factor_maps_thrust_to_output_as_px4(factor, fraction, output):
    mixer = Mixer([RotorGeometry.from_rows(QUAD_X)], idle_output=0.0,
                  thrust_model_factor=np.array([factor]))  # fmt: skip
    out = mix(mixer, np.zeros((1, 3)), np.array([fraction]))
    np.testing.assert_allclose(out[0, :4], output, rtol=1e-12)


def test_thr_mdl_fac_is_read_per_vehicle_and_a_change_rebuilds_the_mixer():
    params = [ParamStore(), ParamStore({"THR_MDL_FAC": 0.3})]
    loop = InnerLoop.from_params(params)
    np.testing.assert_allclose(loop.mixer.thrust_model_factor, [0.0, 0.3])
    params[0].set("THR_MDL_FAC", 1.0)
    loop.set_params(params)
    np.testing.assert_allclose(loop.mixer.thrust_model_factor, [1.0, 0.3])
    with pytest.raises(ValueError, match="thrust_model_factor"):
        Mixer([RotorGeometry.from_rows(QUAD_X)], thrust_model_factor=np.array([1.5]))
