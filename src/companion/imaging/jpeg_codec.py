"""JPEG through OpenCV with the codec's API: the baseline, and a stand-in where no model is.

The pipeline plans with each level's expected bits per pixel; for JPEG those are ASSUMED figures
for 320x240 frames (the mean of 5 synthetic textures of ``image_source``, seed 0), not the
held-out means the learned codec stores with its model. Select it with
``python -m companion.roles --codec jpeg``.
"""

from __future__ import annotations

import numpy as np

from companion.imaging.relay import CodecApi

JPEG_QUALITY = {1: 10, 2: 25, 3: 50, 4: 75, 5: 90}
"""OpenCV JPEG quality (0-100) of each level."""
JPEG_BITS_PER_PIXEL = {1: 0.40, 2: 0.63, 3: 0.88, 4: 1.26, 5: 2.17}
"""Expected bits per pixel of each level (assumption, see the module docstring)."""


class JpegStreamError(ValueError):
    """Bytes that OpenCV cannot decode as a JPEG image."""


JPEG_S_PER_MEGAPIXEL = 0.02
"""Encode or decode time per megapixel on the companion, s (ASSUMPTION: libjpeg-turbo is about
15 times faster than the learned codec on one core here, 0.7 ms for a 320x240 frame)."""


def encode(image: np.ndarray, level: int) -> bytes:
    """Encode RGB uint8 (H, W, 3) at ``level`` (1-5) as JPEG.

    Raises:
        ValueError: not an RGB uint8 image, or an unknown level.
    """
    import cv2

    if level not in JPEG_QUALITY:
        raise ValueError(f"level: {level} is not one of {tuple(JPEG_QUALITY)}")
    if not (isinstance(image, np.ndarray) and image.dtype == np.uint8 and image.ndim == 3):
        raise ValueError("image: expected an RGB uint8 array (H, W, 3)")
    if image.shape[2] != 3 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"image: expected shape (H >= 1, W >= 1, 3), got {image.shape}")
    bgr = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, buffer = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY[level]])
    if not ok:
        raise ValueError("image: OpenCV could not encode it as JPEG")
    return buffer.tobytes()


def decode(data: bytes) -> np.ndarray:
    """Decode JPEG bytes to RGB uint8.

    Raises:
        JpegStreamError: not a JPEG stream OpenCV can decode.
    """
    import cv2

    bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR) if data else None
    if bgr is None:
        raise JpegStreamError(f"not a decodable JPEG stream ({len(data)} bytes)")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def jpeg_codec() -> CodecApi:
    """The JPEG codec as the pipeline's ``CodecApi``."""
    return CodecApi(
        tuple(JPEG_QUALITY),
        encode,
        decode,
        dict(JPEG_BITS_PER_PIXEL),
        (ValueError,),
        s_per_megapixel=JPEG_S_PER_MEGAPIXEL,
    )
