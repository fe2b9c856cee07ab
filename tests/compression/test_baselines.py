"""JPEG and WebP baselines: round trips, rate grows with quality, the protocol, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic_images import one_torch_thread, synthetic_image  # noqa: F401 (autouse fixture)

from compression import metrics
from compression.baselines import ImageCodec, JpegCodec, WebpCodec

CODECS = [JpegCodec(), WebpCodec()]


@pytest.mark.parametrize("codec", CODECS, ids=lambda c: c.name)
@pytest.mark.parametrize("shape", [(176, 208), (37, 51), (1, 1)])
def test_round_trip_keeps_shape_dtype_and_colours(codec, shape):
    """Decoding gives an RGB uint8 image of the same shape, close to the original (no R/B swap)."""
    img = synthetic_image(0, *shape) if min(shape) > 20 else np.full((*shape, 3), 7, np.uint8)
    if min(shape) > 20:
        img[..., 0] = 230  # strong red: a BGR/RGB mix-up would show in the red channel
        img[..., 2] = 20
    out = codec.decode(codec.encode(img, 90))
    assert out.dtype == np.uint8
    assert out.shape == img.shape
    assert np.abs(out.astype(int) - img).mean() < 6
    assert abs(float(out[..., 0].mean()) - float(img[..., 0].mean())) < 6


@pytest.mark.parametrize("codec", CODECS, ids=lambda c: c.name)
def test_more_quality_more_bytes_less_error(codec):
    """Across 10 / 50 / 95 the stream grows and PSNR rises; same input gives the same bytes."""
    img = synthetic_image(1)
    streams = [codec.encode(img, q) for q in (10, 50, 95)]
    psnrs = [metrics.psnr_db(img, codec.decode(s)) for s in streams]
    assert [len(s) for s in streams] == sorted(len(s) for s in streams)
    assert psnrs == sorted(psnrs)
    assert codec.encode(img, 50) == streams[1]


def test_streams_are_real_jpeg_and_webp():
    """The bytes are standard JPEG (SOI marker) and WebP (RIFF....WEBP) files."""
    img = synthetic_image(2)
    assert JpegCodec().encode(img, 50)[:2] == b"\xff\xd8"
    data = WebpCodec().encode(img, 50)
    assert data[:4] == b"RIFF"
    assert data[8:12] == b"WEBP"


def test_codecs_satisfy_the_protocol_and_sort_settings():
    """Both are ImageCodecs; settings are sorted from fewest bits to best quality."""
    for codec in CODECS:
        assert isinstance(codec, ImageCodec)
        assert list(codec.settings) == sorted(codec.settings)
    assert JpegCodec(settings=(50, 10)).settings == (10, 50)


@pytest.mark.parametrize("quality", [0, 101, 2.5, True])
def test_quality_out_of_range_raises(quality):
    """A quality outside 1..100 (or not an int) is a ValueError naming the quality."""
    with pytest.raises(ValueError, match="quality"):
        JpegCodec().encode(synthetic_image(0), quality)
    with pytest.raises(ValueError, match="quality"):
        WebpCodec(settings=(quality,))


@pytest.mark.parametrize("codec", CODECS, ids=lambda c: c.name)
def test_bad_images_and_streams_raise(codec):
    """Wrong dtype / channels / empty images and undecodable bytes raise ValueError."""
    with pytest.raises(ValueError, match="uint8"):
        codec.encode(np.zeros((8, 8, 3), np.float64), 50)
    with pytest.raises(ValueError, match="RGB"):
        codec.encode(np.zeros((8, 8, 4), np.uint8), 50)
    with pytest.raises(ValueError, match="empty"):
        codec.encode(np.zeros((0, 8, 3), np.uint8), 50)
    with pytest.raises(ValueError, match="decodable"):
        codec.decode(b"not an image at all")
    with pytest.raises(ValueError, match="non-empty"):
        codec.decode(b"")
