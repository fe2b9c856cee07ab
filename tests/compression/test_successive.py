"""Successive compression: the quality vs the raw image never recovers from stage to stage."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from synthetic_images import one_torch_thread, synthetic_image  # noqa: F401 (autouse fixture)

from compression import metrics
from compression.baselines import JpegCodec, WebpCodec
from compression.successive import compress_successively


@pytest.mark.parametrize("codec", [JpegCodec(), WebpCodec()], ids=lambda c: c.name)
def test_quality_vs_raw_falls_along_a_descending_chain(codec):
    """Edge 90 -> fog 50 -> cloud 20: bytes fall and PSNR/SSIM/MS-SSIM vs raw fall at each stage."""
    img = synthetic_image(3)
    stages = compress_successively(img, [90, 50, 20], codec)
    assert [s.stage for s in stages] == [0, 1, 2]
    assert [s.setting for s in stages] == [90, 50, 20]
    for earlier, later in itertools.pairwise(stages):
        assert later.n_bytes < earlier.n_bytes
        assert later.psnr_db_vs_raw < earlier.psnr_db_vs_raw
        assert later.ssim_vs_raw < earlier.ssim_vs_raw
        assert later.ms_ssim_vs_raw < earlier.ms_ssim_vs_raw


def test_stage_fields_are_measured_against_raw_and_previous():
    """Stage 0 compares with the raw image both ways; later stages with their own input."""
    img = synthetic_image(4)
    codec = JpegCodec()
    stages = compress_successively(img, [80, 30], codec)
    first, second = stages
    assert first.psnr_db_vs_raw == first.psnr_db_vs_previous
    assert first.ms_ssim_vs_raw == first.ms_ssim_vs_previous
    # Stage 1 re-encodes stage 0's decoded image, not the raw one.
    expected = codec.decode(codec.encode(first.image, 30))
    assert np.array_equal(second.image, expected)
    assert second.psnr_db_vs_previous == pytest.approx(metrics.psnr_db(first.image, expected))
    assert second.n_bytes == len(codec.encode(first.image, 30))
    assert second.bpp == pytest.approx(8 * second.n_bytes / (img.shape[0] * img.shape[1]))


def test_repeating_the_same_level_loses_little_after_the_first_stage():
    """Generation loss at a fixed quality: later stages add far less loss than the first."""
    img = synthetic_image(5)
    stages = compress_successively(img, [50, 50, 50], JpegCodec())
    first_loss = 1 - stages[0].ms_ssim_vs_raw
    for s in stages[1:]:
        assert 1 - s.ms_ssim_vs_previous < 0.5 * first_loss
        assert s.ms_ssim_vs_raw <= stages[0].ms_ssim_vs_raw + 1e-9


def test_small_images_get_nan_ms_ssim_not_an_error():
    """Below 161 px MS-SSIM is undefined: nan in the stage result, PSNR/SSIM still measured."""
    img = synthetic_image(6, height=64, width=96)
    (stage,) = compress_successively(img, [50], JpegCodec())
    assert math.isnan(stage.ms_ssim_vs_raw)
    assert math.isfinite(stage.psnr_db_vs_raw)


def test_bad_chains_raise():
    """An empty chain or a setting the codec does not have is a ValueError naming levels."""
    img = synthetic_image(7)
    with pytest.raises(ValueError, match="levels"):
        compress_successively(img, [], JpegCodec())
    with pytest.raises(ValueError, match="levels"):
        compress_successively(img, [50, 42], JpegCodec(settings=(10, 50)))
