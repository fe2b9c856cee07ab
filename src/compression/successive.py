"""Successive compression (seed 000): each layer decodes what it received and compresses it again.

The edge UAV compresses its camera frame at ``levels[0]`` and sends it to the fog; the fog decodes
it and, to forward it to the cloud over a narrower link, compresses the *decoded* image again at
``levels[1]`` (possibly a lower level), and so on. The raw frame is only ever seen by the edge, so
each stage adds its own loss on top of the previous ones. ``compress_successively`` runs that
chain and measures, at every stage, the bytes sent and the quality both against the raw image
(what the cloud finally sees vs what the camera saw) and against the previous stage's image (the
loss this stage alone adds).

Pure: no I/O; the codec is any ``ImageCodec`` (the learned codec by default).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from compression.baselines import ImageCodec, LearnedCodec, check_rgb_image
from compression.metrics import ms_ssim_or_nan, psnr_db, ssim


@dataclass(frozen=True)
class StageResult:
    """One stage of a successive-compression chain (stage 0 is the edge's first encode)."""

    stage: int
    """Index in the chain, 0 = edge."""
    setting: int
    """Codec setting (level or quality) this stage encoded at."""
    n_bytes: int
    """Size of the stream this stage sends, bytes."""
    bpp: float
    """Bits per pixel of that stream (8 * bytes / (H * W))."""
    psnr_db_vs_raw: float
    """PSNR of this stage's decoded image against the raw image, dB."""
    ssim_vs_raw: float
    """SSIM against the raw image."""
    ms_ssim_vs_raw: float
    """MS-SSIM against the raw image (``nan`` if the image is too small, see metrics)."""
    psnr_db_vs_previous: float
    """PSNR against the previous stage's decoded image (the raw image for stage 0), dB."""
    ssim_vs_previous: float
    """SSIM against the previous stage's decoded image."""
    ms_ssim_vs_previous: float
    """MS-SSIM against the previous stage's decoded image (``nan`` if undefined)."""
    image: np.ndarray = field(repr=False, compare=False)
    """The image this stage's receiver decodes, RGB uint8."""


def compress_successively(
    image: np.ndarray, levels: Sequence[int], codec: ImageCodec | None = None
) -> list[StageResult]:
    """Encode ``image`` at ``levels[0]``, decode, re-encode the result at ``levels[1]``, ...

    Args:
        image: The raw RGB ``uint8`` ``(H, W, 3)`` frame seen by the edge.
        levels: One codec setting per stage, edge first; must not be empty.
        codec: The codec every stage uses; ``None`` for the package's learned codec.

    Returns:
        One ``StageResult`` per stage, in order.
    """
    check_rgb_image(image)
    if len(levels) == 0:
        raise ValueError("levels must name at least one stage")
    if codec is None:
        codec = LearnedCodec()
    for level in levels:
        if level not in codec.settings:
            raise ValueError(f"levels: {level} is not a setting of {codec.name} {codec.settings}")
    n_pixels = image.shape[0] * image.shape[1]
    results: list[StageResult] = []
    previous = image
    for stage, level in enumerate(levels):
        data = codec.encode(previous, level)
        decoded = codec.decode(data)
        if decoded.shape != image.shape or decoded.dtype != np.uint8:
            raise ValueError(
                f"{codec.name} decoded a {decoded.shape} {decoded.dtype} image "
                f"from a {image.shape} uint8 one"
            )
        results.append(
            StageResult(
                stage=stage,
                setting=int(level),
                n_bytes=len(data),
                bpp=8.0 * len(data) / n_pixels,
                psnr_db_vs_raw=psnr_db(image, decoded),
                ssim_vs_raw=ssim(image, decoded),
                ms_ssim_vs_raw=ms_ssim_or_nan(image, decoded),
                psnr_db_vs_previous=psnr_db(previous, decoded),
                ssim_vs_previous=ssim(previous, decoded),
                ms_ssim_vs_previous=ms_ssim_or_nan(previous, decoded),
                image=decoded,
            )
        )
        previous = decoded
    return results
