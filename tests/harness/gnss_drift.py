"""How far the truth may move while a vehicle holds what its GNSS says: the receiver's drift.

A vehicle flies where its estimate, which follows its GNSS receiver, says it is; the receiver's
error wanders (sitl/sensors/gps.py: a Gauss-Markov process of per-axis spread eph and correlation
time tau). Over ``elapsed_s`` the error changes by a per-axis spread of
eph sqrt(2 (1 - exp(-elapsed / tau))): what a truth-frame bound must allow on top of the
controller's own error. Computed from the airframe's receiver (its reference accuracy), not
from the simulation.
"""

from __future__ import annotations

import math

from sitl.vehicles.multirotor import load_airframe

DRIFT_SIGMAS = 3.0
"""Bounds allow three spreads of the drift (a 2-D error stays within 3 sigma 99 % of the time)."""


def gnss_drift_m(elapsed_s: float, airframe: str = "typhoon_h480") -> float:
    """Allowance for the GNSS error's change over ``elapsed_s``: DRIFT_SIGMAS spreads, m."""
    gps = load_airframe(airframe).gps
    eph = gps.hdop_reference * gps.uere_m / math.sqrt(2.0)
    change = eph * math.sqrt(2.0 * (1.0 - math.exp(-elapsed_s / gps.bias_correlation_time_s)))
    return DRIFT_SIGMAS * change
