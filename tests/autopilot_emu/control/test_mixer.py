"""Hexa-X allocation produces the torques it is asked for, with the right signs."""

import numpy as np

from autopilot_emu.control.mixer import HEXA_X_ROTORS, YAW_MOMENT_RATIO, Mixer


def _wrench(outputs):
    """Roll, pitch, yaw torque and thrust (per unit max rotor thrust) of motor outputs."""
    r = np.asarray(HEXA_X_ROTORS)
    t = outputs**2  # thrust fraction: thrust ∝ (rotor speed)² ∝ output²
    return np.array(
        [(-r[:, 1] * t).sum(), (r[:, 0] * t).sum(), (r[:, 2] * YAW_MOMENT_RATIO * t).sum(), t.sum()]
    )


def test_pure_thrust_is_symmetric():
    out = Mixer().mix(np.zeros((1, 3)), np.array([0.4]))[0]
    np.testing.assert_allclose(out, np.sqrt(0.4), rtol=2e-3)
    np.testing.assert_allclose(_wrench(out)[:3], 0.0, atol=1e-12)


def test_each_axis_torque_has_the_commanded_sign_and_no_cross_coupling():
    mixer = Mixer()
    for axis in range(3):
        torque = np.zeros((1, 3))
        torque[0, axis] = 0.1
        w = _wrench(mixer.mix(torque, np.array([0.4]))[0])
        assert w[axis] > 0
        others = [k for k in range(3) if k != axis]
        assert np.all(np.abs(w[others]) < 1e-9)
        np.testing.assert_allclose(w[3], 6 * 0.4, rtol=1e-9)


def test_saturation_keeps_roll_and_pitch_and_outputs_in_range():
    out = Mixer().mix(np.array([[1.0, 0.0, 1.0]]), np.array([0.9]))[0]
    assert np.all((out >= 0) & (out <= 1))
    assert _wrench(out)[0] > 0


def test_idle_output_when_no_thrust():
    out = Mixer(idle_output=0.15).mix(np.zeros((2, 3)), np.zeros(2))
    np.testing.assert_allclose(out, 0.15)
