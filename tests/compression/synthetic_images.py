"""Small synthetic aerial-like RGB images for the compression tests (seeded, no rendering)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import torch


def synthetic_image(seed: int, height: int = 176, width: int = 208) -> np.ndarray:
    """A smooth two-colour gradient with rectangles ("roofs"), a dark blob ("spill") and noise."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width].astype(np.float32)
    c0, c1 = rng.uniform(40, 200, 3), rng.uniform(40, 200, 3)
    t = (x / width * 0.6 + y / height * 0.4)[..., None]
    img = c0 * (1 - t) + c1 * t
    for _ in range(8):
        r, c = rng.integers(0, height - 20), rng.integers(0, width - 20)
        h, w = rng.integers(8, 40), rng.integers(8, 40)
        img[r : r + h, c : c + w] = rng.uniform(0, 255, 3)
    blob = np.exp(-((x - width * 0.6) ** 2 + (y - height * 0.4) ** 2) / (2 * 25.0**2))
    img *= 1 - 0.6 * blob[..., None]
    img += rng.normal(0, 6, img.shape)
    img = cv2.GaussianBlur(img.astype(np.float32), (3, 3), 0.7)
    return np.clip(img, 0, 255).astype(np.uint8)


def write_synthetic_pngs(directory, count: int = 3) -> list[np.ndarray]:
    """Write ``count`` images as ``NNNNN.png`` (RGB content, BGR on disk as cv2 wants)."""
    directory.mkdir(parents=True, exist_ok=True)
    images = [synthetic_image(seed) for seed in range(count)]
    for i, img in enumerate(images):
        cv2.imwrite(str(directory / f"{i:05d}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    return images


@pytest.fixture(autouse=True)
def one_torch_thread():
    """One torch thread for the SSIM metrics, as the evaluation runs them (faster on a shared CPU).

    Imported by each test module of this folder (the folder's conftest.py belongs to the codec's
    tests).
    """
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)
