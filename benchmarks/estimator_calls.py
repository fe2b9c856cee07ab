"""Median wall time per call of each FleetEstimator method, on the fleet's call pattern.

As ``AutopilotFleet.handle_sensors`` calls them: ``update_mag`` and ``update_baro`` at every IMU
sample with a mask (magnetometer in 2 of 5 samples, barometer in 1 of 5), ``update_imu`` at
250 Hz, ``update_acceleration`` at 50 Hz, ``update_gps`` at 10 Hz. ``*_on``/``*_off``: calls
with the mask set / empty. ``sensors``: the same three as one ``update_sensors`` call (what the
fleet does), timed on a second filter fed the same samples. Medians, so other processes on the
machine matter less.

    python benchmarks/estimator_calls.py --vehicles 1,10
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from autopilot_emu.estimator import GRAVITY_M_S2, FleetEstimator


def run(n: int, ticks: int, warmup: int = 2500) -> dict[str, float]:
    """Median microseconds per call of each method for n vehicles."""
    est, combined = FleetEstimator(n), FleetEstimator(n)
    rng = np.random.default_rng(0)
    ones, none = np.ones(n, dtype=bool), np.zeros(n, dtype=bool)
    lla = np.tile([47.397742, 8.545594, 488.0], (n, 1))
    zeros, alt = np.zeros((n, 3)), np.full(n, 488.0)
    fix, eph, epv, sats = np.full(n, 3), np.full(n, 0.8), np.full(n, 1.2), np.full(n, 12.0)
    times: dict[str, list[int]] = {}
    clock = time.perf_counter_ns

    def timed(name: str, call: object, *args: object) -> None:
        start = clock()
        call(*args)
        if tick >= warmup:
            times.setdefault(name, []).append(clock() - start)

    for tick in range(warmup + ticks):
        acc = np.array([0.0, 0.0, -GRAVITY_M_S2]) + 0.05 * rng.standard_normal((n, 3))
        gyro = 0.003 * rng.standard_normal((n, 3))
        mag = np.array([0.21, 0.01, 0.43]) + 0.002 * rng.standard_normal((n, 3))
        baro = alt + 0.1 * rng.standard_normal(n)
        for filt in (est, combined):
            if not filt.attitude_ok.all():
                filt.align_heading(acc, mag, ~filt.attitude_ok)
        has_mag = tick % 5 in (0, 2)
        timed("mag_on" if has_mag else "mag_off", est.update_mag, mag, ones if has_mag else none)
        timed("imu", est.update_imu, acc, gyro, 1.0 / 250.0)
        has_baro = tick % 5 == 0
        timed(
            "baro_on" if has_baro else "baro_off", est.update_baro, baro, ones if has_baro else none
        )
        mag_mask, baro_mask = ones if has_mag else none, ones if has_baro else none
        timed("sensors", combined.update_sensors, acc, gyro, 0.004, mag, mag_mask, baro, baro_mask)
        if tick % 5 == 0:
            timed("acceleration", est.update_acceleration, 0.02)
        if tick % 25 == 0:
            gps = 0.1 * rng.standard_normal((n, 3))
            timed("gps", est.update_gps, gps, zeros, fix, lla, alt, eph, epv, sats)
            combined.update_gps(gps, zeros, fix, lla, alt, eph, epv, sats)
    return {name: float(np.median(v)) / 1e3 for name, v in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", default="1,10", help="comma-separated fleet sizes, e.g. 1,10")
    parser.add_argument("--ticks", type=int, default=4000, help="IMU samples timed, e.g. 4000")
    args = parser.parse_args()
    print(
        f"machine: {platform.processor() or platform.machine()}; {os.cpu_count()} cores; "
        f"Python {platform.python_version()}; numpy {np.__version__}"
    )
    headline = {}
    for n in (int(v) for v in args.vehicles.split(",")):
        result = run(n, args.ticks)
        print(f"N={n:4d}: " + "  ".join(f"{k} {v:6.1f}" for k, v in result.items()) + "  us/call")
        headline[f"sensors_us_{n}"] = result["sensors"]
        headline[f"gps_us_{n}"] = result["gps"]
    print("RESULT " + " ".join(f"{k}={v:.1f}" for k, v in headline.items()))


if __name__ == "__main__":
    main()
