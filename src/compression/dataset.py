"""Training and held-out images: rendered from the project's scenes, read from PNG, cropped.

The images are made by the simulator's own camera pipeline (``python -m harness.imagery``, see
docs/compression.md). This package is a leaf and does not import the simulator: when a split is
missing it runs that command as a subprocess and reads the PNG files it writes.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np

DEFAULT_IMAGE_ROOT = Path("data") / "imagery"


def ensure_images(directory: Path, split: str, count: int) -> list[Path]:
    """The PNG files of ``directory``, sorted; if none, ``count`` of ``split`` are rendered first.

    A folder that already holds PNGs (a user's own images too) is used as it is.

    Raises:
        RuntimeError: the renderer failed (its exit code and last lines in the message).
    """
    paths = sorted(directory.glob("*.png"))
    if paths:
        return paths
    command = [sys.executable, "-m", "harness.imagery", "--split", split]
    command += ["--count", str(count), "--out", str(directory)]
    print(f"rendering {count} {split} images: {' '.join(command)}", flush=True)
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        tail = (done.stderr or done.stdout).strip().splitlines()[-5:]
        raise RuntimeError(
            f"rendering the {split} images failed (exit {done.returncode}): " + " | ".join(tail)
        )
    paths = sorted(directory.glob("*.png"))
    if not paths:
        raise RuntimeError(f"rendering the {split} images wrote no PNG into {directory}")
    return paths


def read_rgb(path: Path) -> np.ndarray:
    """An RGB uint8 (H, W, 3) image from a file OpenCV reads."""
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise ValueError(f"{path}: not an image OpenCV can read")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def random_batch(
    images: list[np.ndarray], rng: np.random.Generator, batch: int, size_px: int
) -> np.ndarray:
    """A float32 (batch, 3, size, size) batch in [0, 1] of augmented random crops.

    Augmentations an aerial camera sees: any of the 8 flips/rotations (no up in a down-looking
    view), exposure (gain 0.75-1.25) and tone (gamma 0.8-1.25) changes of the lighting.
    """
    out = np.empty((batch, 3, size_px, size_px), dtype=np.float32)
    for i in range(batch):
        image = images[rng.integers(len(images))]
        h, w = image.shape[:2]
        top = rng.integers(h - size_px + 1)
        left = rng.integers(w - size_px + 1)
        crop = image[top : top + size_px, left : left + size_px].astype(np.float32) / 255.0
        crop = np.rot90(crop, k=int(rng.integers(4)))
        if rng.random() < 0.5:
            crop = crop[:, ::-1]
        gain = rng.uniform(0.75, 1.25)
        gamma = np.exp(rng.uniform(np.log(0.8), np.log(1.25)))
        crop = np.clip(crop * gain, 0.0, 1.0) ** gamma
        out[i] = crop.transpose(2, 0, 1)
    return out
