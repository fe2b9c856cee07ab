"""The codec as a companion runs it: ONNX Runtime transforms and ANS coding, no torch.

``Codec.encode`` pads the image to a multiple of 16 by repeating its edge, runs the analysis
transform, scales the latent by the level's gains, rounds it and entropy codes it; ``decode``
reverses that and crops. Both check their input and raise ``CompressionError`` subclasses
naming the problem (``compression.errors``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import onnxruntime as ort

from compression.bitstream import StreamHeader, pack, read_header, unpack
from compression.bundle import ModelBundle, load_bundle
from compression.entropy import LatentCoder
from compression.errors import CompressionError, ModelMismatchError

MAX_SIDE_PX = 65535


def _session(path: Path, threads: int) -> ort.InferenceSession:
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads
    options.inter_op_num_threads = 1
    options.log_severity_level = 3
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def check_image(image: object) -> np.ndarray:
    """The image as a C-contiguous RGB uint8 (H, W, 3) array, or a ``CompressionError`` why not."""
    if not isinstance(image, np.ndarray):
        raise CompressionError(f"image must be a numpy array, got {type(image).__name__}")
    if image.dtype != np.uint8:
        raise CompressionError(f"image dtype must be uint8 (RGB 0..255), got {image.dtype}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise CompressionError(f"image must be RGB of shape (H, W, 3), got shape {image.shape}")
    h, w = image.shape[:2]
    if h == 0 or w == 0:
        raise CompressionError(f"image is empty ({h}x{w})")
    if h > MAX_SIDE_PX or w > MAX_SIDE_PX:
        raise CompressionError(f"image sides must be <= {MAX_SIDE_PX} px, got {h}x{w}")
    return np.ascontiguousarray(image)


class Codec:
    """A loaded model: ``encode(image, level) -> bytes`` and ``decode(bytes) -> image``.

    ``threads`` is ONNX Runtime's intra-op thread count (1 = one core, as the benchmark measures).
    """

    def __init__(self, bundle: ModelBundle, threads: int = 1) -> None:
        if threads < 1:
            raise ValueError(f"threads must be >= 1, got {threads}")
        self.bundle = bundle
        self.levels = bundle.levels
        self.model_id = bundle.model_id
        self._encoder = _session(bundle.directory / "encoder.onnx", threads)
        self._decoder = _session(bundle.directory / "decoder.onnx", threads)
        self._coders = [LatentCoder(t) for t in bundle.tables]

    @classmethod
    def load(cls, model_dir: Path | str | None = None, threads: int = 1) -> Codec:
        """Load a model directory (the shipped default model when ``None``)."""
        return cls(load_bundle(model_dir), threads)

    def latent(self, image: np.ndarray, level: int) -> np.ndarray:
        """The integer latent (C, h, w) of an image at a level (before entropy coding)."""
        index = self.bundle.level_index(level)
        image = check_image(image)
        step = self.bundle.downsampling
        h, w = image.shape[:2]
        padded = np.pad(image, ((0, -h % step), (0, -w % step), (0, 0)), mode="edge")
        x = (padded.transpose(2, 0, 1)[None].astype(np.float32)) / np.float32(255.0)
        (y,) = self._encoder.run(None, {"image": x})
        scaled = y[0] * self.bundle.gains[index][:, None, None]
        return np.rint(scaled).astype(np.int64)

    def encode(self, image: np.ndarray, level: int) -> bytes:
        """Compress an RGB uint8 (H, W, 3) image at a level of ``self.levels``."""
        latent = self.latent(image, level)
        index = self.bundle.level_index(level)
        payload = self._coders[index].encode(latent)
        h, w = image.shape[:2]
        return pack(self.model_id, int(level), h, w, payload)

    def header(self, data: bytes) -> StreamHeader:
        """The stream's header, checked against this model."""
        header = read_header(data)
        if header.model_id != self.model_id:
            raise ModelMismatchError(
                f"stream written by model {header.model_id.hex()}, this codec is model "
                f"{self.model_id.hex()} ({self.bundle.directory})"
            )
        if header.level not in self.levels:
            raise ModelMismatchError(f"stream level {header.level} is not one of {self.levels}")
        return header

    def decode(self, data: bytes) -> np.ndarray:
        """The RGB uint8 (H, W, 3) image of a stream."""
        header = self.header(data)
        _, payload = unpack(data)
        index = self.levels.index(header.level)
        step = self.bundle.downsampling
        shape = (self.bundle.latent_channels, -(-header.height // step), -(-header.width // step))
        latent = self._coders[index].decode(payload, shape)
        return self.synthesize(latent, header.level)[: header.height, : header.width]

    def synthesize(self, latent: np.ndarray, level: int) -> np.ndarray:
        """The RGB uint8 image (16 h, 16 w, 3) of an integer latent (C, h, w) at a level."""
        gains = self.bundle.gains[self.bundle.level_index(level)]
        y = (latent.astype(np.float32) / gains[:, None, None])[None]
        (x,) = self._decoder.run(None, {"latent": y})
        return np.clip(np.rint(x[0] * 255.0), 0, 255).astype(np.uint8).transpose(1, 2, 0).copy()

    def bits_per_pixel(self, level: int) -> float:
        """Mean bits per pixel of a level on the held-out images, recorded with the model."""
        index = self.bundle.level_index(level)
        return float(self.bundle.meta["heldout_bits_per_pixel"][index])
