"""Reading a camera stream in a thread and pairing each frame with the vehicle's latest pose.

A companion flies in asyncio while frames arrive on their own clock; :class:`PosedStreamReader`
opens the stream (``cv2.VideoCapture``, retried until it opens), reads it in a daemon thread,
and hands every frame taken while :attr:`active` is set to :meth:`use` with the pose of that
moment and a camera model sized to the frame. Subclasses say what a frame is for (spills,
people). A failure stops the reading, not the flight: it is kept in :attr:`error`.
"""

from __future__ import annotations

import sys
import threading
import time
import traceback
from abc import ABC, abstractmethod
from typing import Any

import numpy as np

from companion.perception.camera_model import CameraModel

OPEN_RETRY_S = 0.5
"""Wall seconds between two attempts to open a stream that is not there yet."""
READ_RETRY_S = 0.05
"""Wall seconds to wait after a failed read."""


class PosedStreamReader(ABC):
    """The reading thread; subclasses implement :meth:`camera_for` and :meth:`use`.

    ``pose``: an object with ``position_enu_m`` and ``rotation_flu_enu`` (None until known),
    written by the flight's telemetry under ``lock``.
    """

    def __init__(self, uri: str, pose: Any, lock: threading.Lock, name: str) -> None:
        self.uri = uri
        self.pose = pose
        self.lock = lock
        self.frames = 0
        """Frames read."""
        self.frames_used = 0
        """Frames handed to :meth:`use` (taken while active, with a pose)."""
        self.active = threading.Event()
        """Set while frames should be used (the survey, the search)."""
        self.stop = threading.Event()
        self.error: str | None = None
        """The traceback that stopped the reading, if one did."""
        self.camera: CameraModel | None = None
        """The camera model sized to the stream's frames (None before the first frame)."""
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    @abstractmethod
    def camera_for(self, width_px: int, height_px: int) -> CameraModel:
        """The camera model of frames of this size."""

    @abstractmethod
    def use(
        self, rgb: np.ndarray, camera: CameraModel, position: np.ndarray, rotation: Any
    ) -> None:
        """Work on one frame (RGB) taken at ``position`` (ENU, m) with ``rotation`` (FLU -> ENU)."""

    def start(self) -> None:
        """Start reading."""
        self._thread.start()

    def close(self) -> None:
        """Stop reading (waits briefly for the thread)."""
        self.stop.set()
        if self._thread.ident is not None:
            self._thread.join(timeout=5.0)

    def _run(self) -> None:
        import cv2

        capture = None
        try:
            while not self.stop.is_set() and capture is None:
                capture = cv2.VideoCapture(self.uri)
                if not capture.isOpened():
                    capture.release()
                    capture = None
                    time.sleep(OPEN_RETRY_S)
            while capture is not None and not self.stop.is_set():
                ok, bgr = capture.read()
                if not ok:
                    time.sleep(READ_RETRY_S)
                    continue
                self.frames += 1
                with self.lock:
                    position, rotation = self.pose.position_enu_m, self.pose.rotation_flu_enu
                if not self.active.is_set() or position is None or rotation is None:
                    continue
                h, w = bgr.shape[:2]
                camera = self.camera
                if camera is None or (camera.width_px, camera.height_px) != (w, h):
                    camera = self.camera = self.camera_for(w, h)
                self.use(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), camera, position, rotation)
                self.frames_used += 1
        except Exception:  # the flight goes on without the camera; reported in the result
            self.error = traceback.format_exc()
            print(self.error, file=sys.stderr, flush=True)
        finally:
            if capture is not None:
                capture.release()
