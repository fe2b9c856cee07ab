"""The codecs the learned one is compared with (JPEG, WebP through OpenCV) and their protocol.

``ImageCodec`` is what the evaluation and successive compression need from any codec: a name,
the settings to sweep (JPEG/WebP quality 1..100, the learned codec's levels) and
``encode(image, setting) -> bytes`` / ``decode(bytes) -> image`` on RGB ``uint8`` arrays.
``LearnedCodec`` adapts the package's own codec (``compression.encode/decode/LEVELS``) to it;
the import is lazy, so this module works before (or without) the trained model.

Baseline settings, chosen to make them as strong as a user would get them for free:

* JPEG: libjpeg through ``cv2.imencode(".jpg")`` with ``IMWRITE_JPEG_OPTIMIZE=1`` (optimised
  Huffman tables, lossless, 5-60 % fewer bytes at low quality), OpenCV's default 4:2:0 chroma
  subsampling, baseline (not progressive).
* WebP: libwebp lossy through ``cv2.imencode(".webp")``; quality 100 is still lossy (OpenCV
  switches to lossless only above 100).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import cv2
import numpy as np

QUALITY_MIN = 1
QUALITY_MAX = 100


@runtime_checkable
class ImageCodec(Protocol):
    """A lossy image codec as the evaluation sees it."""

    name: str
    """Short name used in tables and plots ("jpeg", "webp", "learned")."""

    settings: tuple[int, ...]
    """The settings swept by the evaluation, from fewest bits to best quality."""

    def encode(self, image: np.ndarray, setting: int) -> bytes:
        """Compress an RGB ``uint8`` ``(H, W, 3)`` image at one setting."""
        ...

    def decode(self, data: bytes) -> np.ndarray:
        """Decompress to an RGB ``uint8`` ``(H, W, 3)`` image."""
        ...


def check_rgb_image(image: np.ndarray) -> None:
    """Raise ``ValueError`` unless ``image`` is a non-empty RGB ``uint8`` ``(H, W, 3)`` array."""
    if not isinstance(image, np.ndarray):
        raise ValueError(f"image must be a numpy array, got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise ValueError(f"image must be uint8 RGB, got dtype {image.dtype}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"image must have shape (H, W, 3) (RGB), got {image.shape}")
    if image.shape[0] == 0 or image.shape[1] == 0:
        raise ValueError(f"image is empty: shape {image.shape}")


def _check_quality(quality: int) -> None:
    if isinstance(quality, bool) or not isinstance(quality, int | np.integer):
        raise ValueError(f"quality must be an int in {QUALITY_MIN}..{QUALITY_MAX}, got {quality!r}")
    if not QUALITY_MIN <= quality <= QUALITY_MAX:
        raise ValueError(f"quality must be in {QUALITY_MIN}..{QUALITY_MAX}, got {quality}")


def _check_settings(settings: Sequence[int]) -> tuple[int, ...]:
    """Validate a quality sweep; returns it as a sorted tuple."""
    if len(settings) == 0:
        raise ValueError("settings must not be empty")
    for q in settings:
        _check_quality(q)
    return tuple(sorted(int(q) for q in settings))


def _opencv_encode(image: np.ndarray, ext: str, params: list[int]) -> bytes:
    check_rgb_image(image)
    ok, buf = cv2.imencode(ext, cv2.cvtColor(image, cv2.COLOR_RGB2BGR), params)
    if not ok:
        raise ValueError(f"OpenCV could not encode a {image.shape} image as {ext}")
    return buf.tobytes()


def _opencv_decode(data: bytes, what: str) -> np.ndarray:
    if not isinstance(data, bytes | bytearray | memoryview) or len(data) == 0:
        raise ValueError(f"{what} data must be non-empty bytes")
    bgr = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"not a decodable {what} stream ({len(data)} bytes)")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


@dataclass(frozen=True)
class JpegCodec:
    """Baseline JPEG (libjpeg via OpenCV, optimised Huffman tables, 4:2:0)."""

    settings: tuple[int, ...] = (1, 3, 5, 10, 15, 20, 25, 30, 40, 50, 60, 70, 80, 90, 95)
    """JPEG qualities swept by the evaluation."""
    name: str = "jpeg"

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", _check_settings(self.settings))

    def encode(self, image: np.ndarray, setting: int) -> bytes:
        """JPEG bytes of an RGB image at quality ``setting`` (1..100)."""
        _check_quality(setting)
        params = [cv2.IMWRITE_JPEG_QUALITY, int(setting), cv2.IMWRITE_JPEG_OPTIMIZE, 1]
        return _opencv_encode(image, ".jpg", params)

    def decode(self, data: bytes) -> np.ndarray:
        """RGB image of JPEG bytes."""
        return _opencv_decode(data, "JPEG")


@dataclass(frozen=True)
class WebpCodec:
    """Baseline lossy WebP (libwebp via OpenCV)."""

    settings: tuple[int, ...] = (1, 3, 5, 10, 15, 20, 25, 30, 40, 50, 60, 70, 80, 90, 95, 100)
    """WebP qualities swept by the evaluation."""
    name: str = "webp"

    def __post_init__(self) -> None:
        object.__setattr__(self, "settings", _check_settings(self.settings))

    def encode(self, image: np.ndarray, setting: int) -> bytes:
        """Lossy WebP bytes of an RGB image at quality ``setting`` (1..100)."""
        _check_quality(setting)
        return _opencv_encode(image, ".webp", [cv2.IMWRITE_WEBP_QUALITY, int(setting)])

    def decode(self, data: bytes) -> np.ndarray:
        """RGB image of WebP bytes."""
        return _opencv_decode(data, "WebP")


@dataclass
class LearnedCodec:
    """The package's learned codec behind the ``ImageCodec`` protocol (levels as settings).

    ``threads`` is passed to ``compression.Codec.load`` when given (ONNX Runtime intra-op
    threads; the timing uses 1, as on one core of a companion computer); ``None`` uses the
    package's default codec through ``compression.encode/decode``.
    """

    threads: int | None = None
    """ONNX Runtime threads, or ``None`` for the package default."""
    name: str = "learned"
    settings: tuple[int, ...] = field(init=False)
    _codec: object = field(init=False, repr=False)

    def __post_init__(self) -> None:
        import compression  # lazy: the model may not be there when the baselines are used

        if not hasattr(compression, "encode"):
            raise RuntimeError(
                "the learned codec is not available: compression.encode/decode are missing"
            )
        self.settings = tuple(int(level) for level in compression.LEVELS)
        self._codec = compression if self.threads is None else _load_codec(self.threads)

    def encode(self, image: np.ndarray, setting: int) -> bytes:
        """Codec bytes of an RGB image at level ``setting``."""
        return self._codec.encode(image, setting)

    def decode(self, data: bytes) -> np.ndarray:
        """RGB image of codec bytes."""
        return self._codec.decode(data)


def _load_codec(threads: int) -> object:
    """The package codec loaded with ``threads`` ONNX Runtime threads."""
    import compression

    return compression.Codec.load(threads=threads)
