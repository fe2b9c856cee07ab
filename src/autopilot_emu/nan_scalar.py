"""Scalar minimum, maximum and sign with numpy's NaN rules, for the numba kernels.

``np.minimum`` / ``np.maximum`` / ``np.sign`` on scalars give the same results inside a kernel
but cost far more compile time (ufunc typing at every use); these are plain comparisons.
A NaN in either argument gives NaN, as numpy's.
"""

from __future__ import annotations

import numba


@numba.njit(cache=True)
def fmin(a: float, b: float) -> float:
    """numpy.minimum of two floats (NaN if either is NaN)."""
    return a if (a <= b or a != a) else b


@numba.njit(cache=True)
def fmax(a: float, b: float) -> float:
    """numpy.maximum of two floats (NaN if either is NaN)."""
    return a if (a >= b or a != a) else b


@numba.njit(cache=True)
def clamp(x: float, lo: float, hi: float) -> float:
    """numpy.minimum(numpy.maximum(x, lo), hi)."""
    return fmin(fmax(x, lo), hi)


@numba.njit(cache=True)
def sign(x: float) -> float:
    """numpy.sign of a float: -1, 0 or 1 (NaN stays NaN)."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x  # 0.0, -0.0 or NaN
