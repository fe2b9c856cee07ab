"""The shipped model through the public API: shapes, errors, determinism, quality per level."""

from itertools import pairwise

import numpy as np
import pytest
import torch
from pytorch_msssim import ms_ssim

import compression
from compression import Codec, CompressionError, ModelMismatchError, StreamError
from compression.export import export_model
from compression.model import Autoencoder, ModelConfig


@pytest.mark.parametrize("shape", [(1, 1), (17, 5), (16, 16), (241, 321), (7, 500), (480, 640)])
def test_round_trip_keeps_any_shape(shape):
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    for level in (compression.LEVELS[0], compression.LEVELS[-1]):
        data = compression.encode(image, level)
        header = compression.read_header(data)
        assert (header.height, header.width, header.level) == (*shape, level)
        out = compression.decode(data)
        assert out.shape == image.shape and out.dtype == np.uint8


def test_non_contiguous_views_are_accepted(scene_images):
    image = scene_images[0]
    view = image[::-1, 10:250]
    assert np.array_equal(compression.decode(compression.encode(view, 3)).shape, view.shape)
    assert compression.encode(view, 3) == compression.encode(view.copy(), 3)


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.zeros((8, 8, 3), dtype=np.float32), "dtype"),
        (np.zeros((8, 8, 3), dtype=np.uint16), "dtype"),
        (np.zeros((8, 8), dtype=np.uint8), "shape"),
        (np.zeros((8, 8, 4), dtype=np.uint8), "shape"),
        (np.zeros((0, 8, 3), dtype=np.uint8), "empty"),
        ([[0, 0, 0]], "numpy array"),
    ],
)
def test_bad_images_raise_naming_the_problem(image, match):
    with pytest.raises(CompressionError, match=match):
        compression.encode(image, 3)


@pytest.mark.parametrize("level", [0, 6, 2.0, True, "3", None])
def test_unknown_levels_raise(level):
    with pytest.raises(CompressionError, match="level must be one of"):
        compression.encode(np.zeros((8, 8, 3), dtype=np.uint8), level)


def test_same_input_and_level_give_identical_bytes(scene_images):
    for level in compression.LEVELS:
        assert compression.encode(scene_images[1], level) == compression.encode(
            scene_images[1], level
        )


def test_quality_and_bits_increase_with_level(scene_images):
    images = scene_images[:6]
    reference = torch.from_numpy(np.stack(images)).permute(0, 3, 1, 2).float()
    bits, quality = [], []
    for level in compression.LEVELS:
        streams = [compression.encode(image, level) for image in images]
        decoded = np.stack([compression.decode(s) for s in streams])
        bits.append(sum(len(s) for s in streams))
        out = torch.from_numpy(decoded).permute(0, 3, 1, 2).float()
        quality.append(float(ms_ssim(out, reference, data_range=255)))
    assert all(a < b for a, b in pairwise(bits)), bits
    assert all(a < b for a, b in pairwise(quality)), quality
    assert quality[-1] > 0.95


def test_damaged_streams_raise(scene_images):
    data = compression.encode(scene_images[2], 4)
    with pytest.raises(StreamError, match="truncated"):
        compression.decode(data[:-1])
    with pytest.raises(StreamError, match="truncated"):
        compression.decode(data[:10])
    with pytest.raises(StreamError):
        compression.decode(b"")
    rng = np.random.default_rng(3)
    for i in rng.integers(0, len(data), 40):
        damaged = bytearray(data)
        damaged[i] ^= 0x10
        with pytest.raises(StreamError):
            compression.decode(bytes(damaged))


def test_stream_from_another_model_is_refused(tmp_path, scene_images):
    torch.manual_seed(0)
    export_model(
        Autoencoder(ModelConfig()),
        tmp_path,
        compression.LEVELS,
        {"heldout_bits_per_pixel": [1.0] * 5},
    )
    other = Codec.load(tmp_path)
    assert other.model_id != compression.default_codec().model_id
    data = other.encode(scene_images[0][:32, :48], 2)
    with pytest.raises(ModelMismatchError, match="model"):
        compression.decode(data)
    assert other.decode(data).shape == (32, 48, 3)


def test_missing_model_directory_says_what_is_missing(tmp_path):
    with pytest.raises(CompressionError, match=r"encoder\.onnx"):
        Codec.load(tmp_path)


def test_level_rates_are_recorded_and_ordered():
    rates = [compression.level_bits_per_pixel(level) for level in compression.LEVELS]
    assert all(0 < a < b for a, b in pairwise(rates)), rates
