"""The kernels' scalar min / max / clamp / sign follow numpy's NaN rules."""

from __future__ import annotations

import itertools
import math

import numpy as np

from autopilot_emu.nan_scalar import clamp, fmax, fmin, sign

VALUES = (-2.0, -0.5, 0.0, 0.5, 3.0, math.inf, -math.inf, math.nan)


def same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


def test_min_max_clamp_sign_match_numpy_including_nan_and_inf():
    for a, b in itertools.product(VALUES, VALUES):
        assert same(fmin(a, b), float(np.minimum(a, b))), (a, b)
        assert same(fmax(a, b), float(np.maximum(a, b))), (a, b)
        for hi in VALUES:
            want = float(np.minimum(np.maximum(a, b), hi))
            assert same(clamp(a, b, hi), want), (a, b, hi)
    for a in VALUES:
        assert same(sign(a), float(np.sign(a))), a
