"""Where the edge's images come from: the camera stream, a directory of PNGs, or a callable.

Every source is a callable returning the next RGB ``uint8`` image (H, W, 3), or None when it has
none yet (a stream that has not delivered its first frame). Priority in the edge role: the
vehicle's camera stream (``SWARMSITL_VIDEO_URI``), else a directory given with ``--images``,
else a synthetic aerial-like texture, so that the link always carries real codec output.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ImageSource = Callable[[], "np.ndarray | None"]
"""Returns the next RGB uint8 image, or None if none is available yet."""
OPEN_RETRY_S = 0.5
"""Wall seconds between two attempts to open a stream that is not there yet."""
READ_RETRY_S = 0.05
"""Wall seconds to wait after a failed read."""


class DirectoryImages:
    """The PNG (and JPEG) files of a directory in name order, cycled."""

    def __init__(self, directory: str | Path) -> None:
        self.directory = Path(directory)
        if not self.directory.is_dir():
            raise ValueError(f"images: {self.directory} is not a directory")
        self.files = sorted(
            p for p in self.directory.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg")
        )
        if not self.files:
            raise ValueError(f"images: no .png or .jpg files in {self.directory}")
        self._next = 0

    def __call__(self) -> np.ndarray:
        """The next file's image as RGB.

        Raises:
            ValueError: the file is not a readable image (names it).
        """
        import cv2

        path = self.files[self._next % len(self.files)]
        self._next += 1
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise ValueError(f"images: cannot read {path} as an image")
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


class StreamImages:
    """The latest frame of a video stream (``cv2.VideoCapture(uri)``), read in a daemon thread.

    A companion's camera delivers frames on its own clock; the edge sends one every image
    period, so only the latest is kept. A failure stops the reading (``error``), not the role.
    """

    def __init__(self, uri: str) -> None:
        self.uri = uri
        self.frames = 0
        """Frames read."""
        self.error: str | None = None
        """Why the reading stopped, if it did."""
        self._latest: np.ndarray | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="image-stream", daemon=True)
        self._thread.start()

    def __call__(self) -> np.ndarray | None:
        """The latest frame (RGB), None before the first."""
        with self._lock:
            return self._latest

    def close(self) -> None:
        """Stop reading."""
        self._stop.set()
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        import cv2

        capture = None
        try:
            while not self._stop.is_set() and capture is None:
                capture = cv2.VideoCapture(self.uri)
                if not capture.isOpened():
                    capture.release()
                    capture = None
                    time.sleep(OPEN_RETRY_S)
            while capture is not None and not self._stop.is_set():
                ok, bgr = capture.read()
                if not ok:
                    time.sleep(READ_RETRY_S)
                    continue
                rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
                with self._lock:
                    self._latest = rgb
                    self.frames += 1
        except Exception as exc:  # the role goes on without the camera
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            if capture is not None:
                capture.release()


class SyntheticImages:
    """Smooth random textures (sea-, field-like) with a few sharp patches; deterministic.

    Stand-in for a camera when there is none: natural images are smooth with edges, unlike
    white noise (which no codec compresses), so the codec's sizes stay meaningful.
    """

    def __init__(self, rng: np.random.Generator, width_px: int = 320, height_px: int = 240) -> None:
        if width_px < 1 or height_px < 1:
            raise ValueError(f"width_px, height_px: must be >= 1, got {width_px}, {height_px}")
        self.rng = rng
        self.width_px = width_px
        self.height_px = height_px

    def __call__(self) -> np.ndarray:
        """A new texture."""
        import cv2

        h, w = self.height_px, self.width_px
        coarse = self.rng.uniform(0, 255, size=(max(2, h // 16), max(2, w // 16), 3))
        image = cv2.resize(coarse.astype(np.float32), (w, h), interpolation=cv2.INTER_CUBIC)
        image += self.rng.normal(0, 4, size=image.shape).astype(np.float32)
        for _ in range(3):  # dark patches with sharp borders (a spill, a roof)
            y, x = self.rng.integers(0, h), self.rng.integers(0, w)
            r = int(self.rng.integers(2, max(3, min(h, w) // 6)))
            image[max(0, y - r) : y + r, max(0, x - r) : x + r] *= 0.3
        return np.clip(image, 0, 255).astype(np.uint8)
