"""The learned image codec a companion runs (seed 000's autoencoder compression).

``encode(image, level) -> bytes`` and ``decode(data) -> image`` for RGB uint8 (H, W, 3) arrays of
any size, with the shipped model (ONNX Runtime, no torch needed); ``LEVELS`` lists the levels,
1 = fewest bits. ``Codec.load(model_dir)`` loads another model. See docs/compression.md.
"""

from __future__ import annotations

import threading

import numpy as np

from compression.bitstream import FORMAT_VERSION, StreamHeader, read_header
from compression.codec import Codec
from compression.errors import CompressionError, ModelMismatchError, StreamError

LEVELS: tuple[int, ...] = (1, 2, 3, 4, 5)
"""Compression levels of the shipped model: 1 = fewest bits, 5 = best quality."""

_default: Codec | None = None
_lock = threading.Lock()


def default_codec() -> Codec:
    """The shipped model, loaded once per process (one ONNX Runtime thread)."""
    global _default
    with _lock:
        if _default is None:
            codec = Codec.load()
            if codec.levels != LEVELS:
                raise CompressionError(
                    f"shipped model has levels {codec.levels}, expected {LEVELS}"
                )
            _default = codec
        return _default


def encode(image: np.ndarray, level: int) -> bytes:
    """Compress an RGB uint8 (H, W, 3) image at one of ``LEVELS`` with the shipped model."""
    return default_codec().encode(image, level)


def decode(data: bytes) -> np.ndarray:
    """The RGB uint8 (H, W, 3) image of a stream ``encode`` wrote."""
    return default_codec().decode(data)


def level_bits_per_pixel(level: int) -> float:
    """Mean bits per pixel of a level on the held-out rendered images (from training time)."""
    return default_codec().bits_per_pixel(level)


__all__ = [
    "FORMAT_VERSION",
    "LEVELS",
    "Codec",
    "CompressionError",
    "ModelMismatchError",
    "StreamError",
    "StreamHeader",
    "decode",
    "default_codec",
    "encode",
    "level_bits_per_pixel",
    "read_header",
]
