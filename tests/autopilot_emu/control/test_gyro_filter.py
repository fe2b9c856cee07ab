"""The rate controller's gyro filters against the properties of a Butterworth low-pass.

Oracles: a second-order Butterworth passes its cutoff frequency at -3 dB (gain 1/sqrt(2)) with a
90 deg lag, and the bilinear transform with a pre-warped cutoff keeps that exactly; far below
the cutoff the gain is 1. The D-term signal is the derivative of the filtered rate: a rate
ramping at a constant angular acceleration must read that acceleration once settled.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot_emu.control.gyro_filter import PASS_THROUGH, butterworth2
from autopilot_emu.control.inner_loop import InnerLoop, InnerLoopGains
from autopilot_emu.control.mixer import Mixer
from autopilot_emu.params import ParamStore

RATE_HZ = 250.0


def run_loop(loop: InnerLoop, rates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Feed body rates (T, 3) of one vehicle sample by sample; filtered rates and accelerations."""
    n = 1
    filtered, accel = [], []
    for r in rates:
        loop.step(
            q=np.array([[1.0, 0.0, 0.0, 0.0]]),
            rates_rad_s=r.reshape(1, 3),
            q_sp=np.array([[1.0, 0.0, 0.0, 0.0]]),
            thrust=np.full(n, 0.4),
            overridden=np.zeros(n, dtype=bool),
            rate_target_rad_s=np.full((n, 3), np.nan),
            dt_s=1.0 / RATE_HZ,
            active=np.ones(n, dtype=bool),
            armed=np.ones(n, dtype=bool),
        )
        filtered.append(loop.state.rates_filtered_rad_s[0].copy())
        accel.append(loop.state.angular_accel_rad_s2[0].copy())
    return np.array(filtered), np.array(accel)


def px4_loop(**params: float) -> InnerLoop:
    return InnerLoop.from_params([ParamStore(params)], RATE_HZ)


def sine_gain_and_lag(out: np.ndarray, freq_hz: float, t: np.ndarray) -> tuple[float, float]:
    """Amplitude and phase lag (rad) of ``out`` at ``freq_hz`` by projection on sin and cos."""
    s, c = np.sin(2 * np.pi * freq_hz * t), np.cos(2 * np.pi * freq_hz * t)
    a, b = 2 * np.mean(out * s), 2 * np.mean(out * c)
    return math.hypot(a, b), -math.atan2(b, a)


def sine_response(cutoff_hz: float, freq_hz: float) -> tuple[float, float]:
    """Settled gain and lag of the IMU_GYRO_CUTOFF filter on a roll-rate sine of ``freq_hz``."""
    t = np.arange(2000) / RATE_HZ
    rates = np.zeros((len(t), 3))
    rates[:, 0] = np.sin(2 * np.pi * freq_hz * t)
    filtered, _ = run_loop(px4_loop(IMU_GYRO_CUTOFF=cutoff_hz), rates)
    keep = t >= 2.0
    return sine_gain_and_lag(filtered[keep, 0], freq_hz, t[keep])


@pytest.mark.parametrize("cutoff_hz", [40.0, 20.0])
def test_the_cutoff_frequency_passes_at_minus_3_db_and_90_degrees_lag(cutoff_hz):
    gain, lag = sine_response(cutoff_hz, cutoff_hz)
    assert gain == pytest.approx(1 / math.sqrt(2), rel=1e-3)
    assert lag == pytest.approx(math.pi / 2, abs=1e-3)
    low_gain, _ = sine_response(cutoff_hz, 1.0)
    assert low_gain == pytest.approx(1.0, abs=2e-3)


def test_the_d_term_reads_a_constant_angular_acceleration_of_a_ramping_rate():
    loop = px4_loop()
    t = np.arange(500) / RATE_HZ
    alpha = np.array([3.0, -2.0, 0.5])  # rad/s²
    _, accel = run_loop(loop, t[:, None] * alpha)
    np.testing.assert_allclose(accel[-1], alpha, rtol=1e-6)
    # The first sample primes the filters: no derivative kick from the start value.
    np.testing.assert_array_equal(accel[0], 0.0)


def test_px4_defaults_and_zero_disable_the_filters():
    g = InnerLoopGains.from_params([ParamStore()], RATE_HZ)
    np.testing.assert_allclose(g.filters[0, 0], butterworth2(40.0, RATE_HZ))
    np.testing.assert_allclose(g.filters[1, 0], butterworth2(20.0, RATE_HZ))
    off = InnerLoopGains.from_params([ParamStore({"IMU_GYRO_CUTOFF": 0.0})], RATE_HZ)
    np.testing.assert_array_equal(off.filters[0, 0], PASS_THROUGH)
    # At or above Nyquist no Butterworth exists: PX4 disables the filter, so does this.
    np.testing.assert_array_equal(butterworth2(125.0, RATE_HZ), PASS_THROUGH)
    with pytest.raises(ValueError, match="sample rate"):
        butterworth2(40.0, 0.0)


def test_a_non_finite_sample_does_not_poison_the_filter():
    loop = px4_loop()
    rates = np.full((60, 3), 0.2)
    rates[30, 1] = np.nan
    filtered, accel = run_loop(loop, rates)
    assert np.isnan(filtered[30, 1]) and np.isnan(accel[30, 1])
    np.testing.assert_allclose(filtered[31:, 1], 0.2, rtol=1e-9)
    np.testing.assert_allclose(accel[31:, 1], 0.0, atol=1e-9)


def test_rate_k_scales_p_i_and_d():
    base = InnerLoopGains.from_params([ParamStore()], RATE_HZ)
    scaled = InnerLoopGains.from_params([ParamStore({"MC_PITCHRATE_K": 2.0})], RATE_HZ)
    for name in ("rate_p", "rate_i", "rate_d"):
        np.testing.assert_allclose(getattr(scaled, name)[0, 1], 2 * getattr(base, name)[0, 1])
        np.testing.assert_allclose(getattr(scaled, name)[0, [0, 2]], getattr(base, name)[0, [0, 2]])


def test_a_hand_built_loop_is_unfiltered():
    z = np.zeros((1, 3))
    loop = InnerLoop(InnerLoopGains(z, np.full((1, 3), np.inf), z, z, z), Mixer())
    rates = np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]])
    filtered, accel = run_loop(loop, rates)
    np.testing.assert_allclose(filtered[1], [0.4, 0.0, 0.0])
    np.testing.assert_allclose(accel[1], [0.4 * RATE_HZ, 0.0, 0.0])
