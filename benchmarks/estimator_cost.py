"""Cost of the fleet navigation filter per IMU tick, without physics or MAVLink.

Feeds synthetic level-at-rest sensor data on the simulator's schedule (IMU 250 Hz, magnetometer
100 Hz, barometer 50 Hz, GNSS 10 Hz) to ``FleetEstimator`` for N vehicles and reports process
CPU time per IMU tick (best of three runs, so other processes on the machine matter less).

    PYTHONPATH=src python benchmarks/estimator_cost.py --vehicles 1,10,100
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from autopilot_emu.estimator import GRAVITY_M_S2, FleetEstimator

IMU_HZ = 250
BARO_EVERY, GPS_EVERY = 5, 25
"""IMU ticks between barometer and GNSS samples (the magnetometer alternates 2 and 3)."""


def run(n: int, ticks: int) -> float:
    """CPU microseconds per IMU tick for n vehicles."""
    est = FleetEstimator(n)
    rng = np.random.default_rng(0)
    acc = np.tile([0.0, 0.0, -GRAVITY_M_S2], (n, 1)) + 0.05 * rng.standard_normal((n, 3))
    gyro = 0.003 * rng.standard_normal((n, 3))
    mag = np.tile([0.21, 0.01, 0.43], (n, 1))
    ones = np.ones(n, dtype=bool)
    est.align_heading(acc, mag, ones)
    lla = np.tile([47.397742, 8.545594, 488.0], (n, 1))
    zeros = np.zeros((n, 3))
    alt = np.full(n, 488.0)
    fix, eph, epv, sats = np.full(n, 3), np.full(n, 0.8), np.full(n, 1.2), np.full(n, 12)
    start = time.process_time()
    for k in range(ticks):
        if k % 5 in (0, 2):
            est.update_mag(mag, ones)
        est.update_imu(acc, gyro, 1.0 / IMU_HZ)
        if k % BARO_EVERY == 0:
            est.update_baro(alt, ones)
        if k % GPS_EVERY == 0:
            est.update_gps(zeros, zeros, fix, lla, alt, eph, epv, sats)
    return (time.process_time() - start) / ticks * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", default="1,10,100", help="comma-separated fleet sizes")
    parser.add_argument("--ticks", type=int, default=5000, help="IMU ticks per run")
    args = parser.parse_args()
    for n in (int(v) for v in args.vehicles.split(",")):
        best = min(run(n, args.ticks) for _ in range(3))
        print(f"N={n:4d}: {best:7.1f} us CPU per IMU tick ({best / n:6.2f} us per vehicle)")


if __name__ == "__main__":
    main()
