"""Image quality metrics for RGB ``uint8`` pairs: PSNR, SSIM and MS-SSIM.

Definitions (the ones the evaluation and the successive-compression tables report):

* ``psnr_db``: ``10 log10(255^2 / MSE)`` with the MSE taken over every pixel and all three RGB
  channels together; ``inf`` for identical images. Same value as
  ``skimage.metrics.peak_signal_noise_ratio(a, b, data_range=255)``.
* ``ssim``: structural similarity of Wang et al. 2004 as implemented by ``pytorch_msssim``: an
  11-tap Gaussian window (sigma 1.5), ``K1 = 0.01``, ``K2 = 0.03``, ``data_range = 255``, computed
  on each RGB channel separately (no conversion to luma) over the valid part of the image (no
  padding) and averaged over the three channels. Needs a short side of at least 11 px.
* ``ms_ssim``: multi-scale SSIM of Wang et al. 2003 as implemented by ``pytorch_msssim``: five
  scales with the paper's weights ``(0.0448, 0.2856, 0.3001, 0.2363, 0.1333)``, the same window and
  constants as ``ssim``, per RGB channel, averaged over the channels. With five scales the
  coarsest one is 1/16 of the image, so the short side must be at least ``MS_SSIM_MIN_SIDE_PX``
  (161 px); below that the metric is undefined and ``ms_ssim`` raises ``ValueError`` (no silent
  fallback to fewer scales: numbers from a different definition must not mix in one table).

All functions take ``(H, W, 3)`` ``uint8`` RGB arrays; the ``*_batch`` variants take
``(N, H, W, 3)`` stacks of equal-sized images and return one value per pair (computed pair by
pair: with pytorch_msssim's depthwise convolutions a batch is slower on a CPU than a loop). The SSIM
functions run torch on its current thread count; the evaluation sets one thread, which on a
shared 2-core machine is 2-4x faster than two.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import torch
from pytorch_msssim import ms_ssim as _ms_ssim
from pytorch_msssim import ssim as _ssim

DATA_RANGE = 255.0
"""Value range of a ``uint8`` channel, the ``data_range`` passed to the SSIM constants."""

SSIM_WINDOW_PX = 11
"""Side of the Gaussian SSIM window, px (pytorch_msssim's default)."""

MS_SSIM_SCALES = 5
"""Number of MS-SSIM scales (Wang et al. 2003)."""

MS_SSIM_MIN_SIDE_PX = (SSIM_WINDOW_PX - 1) * 2 ** (MS_SSIM_SCALES - 1) + 1
"""Smallest short side for which five-scale MS-SSIM is defined, px (161)."""


def _check_pair(a: np.ndarray, b: np.ndarray, batched: bool) -> None:
    """Raise ``ValueError`` unless ``a`` and ``b`` are equal-shaped RGB ``uint8`` images."""
    ndim = 4 if batched else 3
    what = "(N, H, W, 3)" if batched else "(H, W, 3)"
    for name, x in (("a", a), ("b", b)):
        if not isinstance(x, np.ndarray):
            raise ValueError(f"{name} must be a numpy array, got {type(x).__name__}")
        if x.dtype != np.uint8:
            raise ValueError(f"{name} must be uint8 RGB, got dtype {x.dtype}")
        if x.ndim != ndim or x.shape[-1] != 3:
            raise ValueError(f"{name} must have shape {what} (RGB), got {x.shape}")
        if x.size == 0:
            raise ValueError(f"{name} is empty: shape {x.shape}")
    if a.shape != b.shape:
        raise ValueError(f"a and b differ in shape: {a.shape} vs {b.shape}")


def _to_tensor(x: np.ndarray) -> torch.Tensor:
    """(H, W, 3) uint8 -> (1, 3, H, W) float32 in 0..255."""
    return torch.from_numpy(x.astype(np.float32)).permute(2, 0, 1)[None]


def _per_pair(fn: Callable[..., torch.Tensor], a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``fn`` (pytorch_msssim's ssim or ms_ssim) on each pair of two (N, H, W, 3) stacks."""
    with torch.no_grad():
        return np.array(
            [
                float(fn(_to_tensor(x), _to_tensor(y), data_range=DATA_RANGE))
                for x, y in zip(a, b, strict=True)
            ],
            dtype=np.float64,
        )


def ms_ssim_defined(height: int, width: int) -> bool:
    """Whether five-scale MS-SSIM is defined for an image of that size."""
    return min(height, width) >= MS_SSIM_MIN_SIDE_PX


def psnr_db_batch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """PSNR of each pair in two ``(N, H, W, 3)`` stacks, dB (``inf`` where identical)."""
    _check_pair(a, b, batched=True)
    diff = a.astype(np.float64) - b.astype(np.float64)
    mse = np.mean(diff * diff, axis=(1, 2, 3))
    with np.errstate(divide="ignore"):
        return np.where(mse > 0.0, 10.0 * np.log10(DATA_RANGE**2 / mse), np.inf)


def ssim_batch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SSIM of each pair in two ``(N, H, W, 3)`` stacks (definition in the module docstring)."""
    _check_pair(a, b, batched=True)
    if min(a.shape[1:3]) < SSIM_WINDOW_PX:
        raise ValueError(
            f"SSIM needs a short side of at least {SSIM_WINDOW_PX} px, got {a.shape[1:3]}"
        )
    return _per_pair(_ssim, a, b)


def ms_ssim_batch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MS-SSIM of each pair in two ``(N, H, W, 3)`` stacks (definition in the module docstring)."""
    _check_pair(a, b, batched=True)
    if not ms_ssim_defined(*a.shape[1:3]):
        raise ValueError(
            f"MS-SSIM with {MS_SSIM_SCALES} scales needs a short side of at least "
            f"{MS_SSIM_MIN_SIDE_PX} px, got an image of {a.shape[1]}x{a.shape[2]} (HxW)"
        )
    return _per_pair(_ms_ssim, a, b)


def psnr_db(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR of two RGB ``uint8`` images, dB; ``inf`` for identical images."""
    _check_pair(a, b, batched=False)
    return float(psnr_db_batch(a[None], b[None])[0])


def ssim(a: np.ndarray, b: np.ndarray) -> float:
    """SSIM of two RGB ``uint8`` images (1.0 for identical images)."""
    _check_pair(a, b, batched=False)
    return float(ssim_batch(a[None], b[None])[0])


def ms_ssim(a: np.ndarray, b: np.ndarray) -> float:
    """MS-SSIM of two RGB ``uint8`` images; ``ValueError`` if the short side is < 161 px."""
    _check_pair(a, b, batched=False)
    return float(ms_ssim_batch(a[None], b[None])[0])


def ms_ssim_or_nan(a: np.ndarray, b: np.ndarray) -> float:
    """MS-SSIM where defined, ``nan`` for images too small for five scales.

    For tables that also hold small images: ``nan`` marks "undefined" and never mixes a
    different definition into the column.
    """
    _check_pair(a, b, batched=False)
    return ms_ssim(a, b) if ms_ssim_defined(*a.shape[:2]) else math.nan
