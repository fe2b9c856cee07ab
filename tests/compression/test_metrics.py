"""Quality metrics: known values, ordering under degradation, agreement with scikit-image."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from skimage.metrics import peak_signal_noise_ratio, structural_similarity
from synthetic_images import one_torch_thread, synthetic_image  # noqa: F401 (autouse fixture)

from compression import metrics


def _noisy(img, sigma, seed=0):
    rng = np.random.default_rng(seed)
    return np.clip(img + rng.normal(0, sigma, img.shape), 0, 255).astype(np.uint8)


def test_identical_images_are_perfect():
    """Identical images: infinite PSNR, SSIM and MS-SSIM exactly 1."""
    img = synthetic_image(1)
    assert metrics.psnr_db(img, img) == math.inf
    assert metrics.ssim(img, img) == pytest.approx(1.0, abs=1e-6)
    assert metrics.ms_ssim(img, img) == pytest.approx(1.0, abs=1e-6)


def test_more_noise_scores_lower_on_every_metric():
    """Each metric decreases strictly as the added Gaussian noise grows."""
    img = synthetic_image(2)
    scores = [
        (metrics.psnr_db(img, n), metrics.ssim(img, n), metrics.ms_ssim(img, n))
        for n in (_noisy(img, s) for s in (2, 8, 30))
    ]
    for better, worse in itertools.pairwise(scores):
        assert all(b > w for b, w in zip(better, worse, strict=True))
    assert all(0.0 < v < 1.0 for _, s, m in scores for v in (s, m))


def test_psnr_agrees_with_skimage_and_known_mse():
    """PSNR equals scikit-image's and 10 log10(255^2/MSE) for a constant offset."""
    img = synthetic_image(3)
    noisy = _noisy(img, 10)
    assert metrics.psnr_db(img, noisy) == pytest.approx(
        peak_signal_noise_ratio(img, noisy, data_range=255), rel=1e-9
    )
    a = np.full((20, 30, 3), 100, np.uint8)
    b = a + np.uint8(5)  # MSE = 25
    assert metrics.psnr_db(a, b) == pytest.approx(10 * math.log10(255**2 / 25))


def test_ssim_close_to_skimage_gaussian_ssim():
    """Our per-channel Gaussian SSIM is within 0.01 of scikit-image's Gaussian-window SSIM."""
    img = synthetic_image(4)
    noisy = _noisy(img, 12)
    reference = structural_similarity(
        img,
        noisy,
        channel_axis=2,
        data_range=255,
        gaussian_weights=True,
        sigma=1.5,
        use_sample_covariance=False,
    )
    assert metrics.ssim(img, noisy) == pytest.approx(reference, abs=0.01)


def test_batch_equals_single_calls():
    """The batched helpers return the same values as one call per pair."""
    a = np.stack([synthetic_image(s) for s in (5, 6)])
    b = np.stack([_noisy(x, 5 + 10 * i) for i, x in enumerate(a)])
    for batch_fn, fn in (
        (metrics.psnr_db_batch, metrics.psnr_db),
        (metrics.ssim_batch, metrics.ssim),
        (metrics.ms_ssim_batch, metrics.ms_ssim),
    ):
        assert batch_fn(a, b) == pytest.approx([fn(a[0], b[0]), fn(a[1], b[1])], rel=1e-6)


def test_ms_ssim_undefined_below_161_px_raises_and_nan_variant():
    """A short side of 160 px is too small for 5 scales: ValueError naming the limit; 161 is ok."""
    small = synthetic_image(7, height=160, width=300)
    with pytest.raises(ValueError, match="161"):
        metrics.ms_ssim(small, small)
    assert math.isnan(metrics.ms_ssim_or_nan(small, small))
    ok = synthetic_image(7, height=161, width=161)
    assert metrics.ms_ssim(ok, ok) == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize(
    ("a", "b", "match"),
    [
        (np.zeros((20, 20, 3), np.float32), np.zeros((20, 20, 3), np.float32), "uint8"),
        (np.zeros((20, 20), np.uint8), np.zeros((20, 20), np.uint8), "RGB"),
        (np.zeros((20, 20, 4), np.uint8), np.zeros((20, 20, 4), np.uint8), "RGB"),
        (np.zeros((20, 20, 3), np.uint8), np.zeros((20, 21, 3), np.uint8), "shape"),
        (np.zeros((0, 20, 3), np.uint8), np.zeros((0, 20, 3), np.uint8), "empty"),
    ],
)
def test_bad_input_is_a_clear_value_error(a, b, match):
    """Wrong dtype, channel count, mismatched or empty shapes raise ValueError naming it."""
    with pytest.raises(ValueError, match=match):
        metrics.psnr_db(a, b)


def test_ssim_needs_the_window():
    """Images smaller than the 11 px window raise instead of a silently unsmoothed SSIM."""
    tiny = np.zeros((8, 40, 3), np.uint8)
    with pytest.raises(ValueError, match="11 px"):
        metrics.ssim(tiny, tiny)
