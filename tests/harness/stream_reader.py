"""Read a camera stream with OpenCV in another process while a Simulation runs (paced)."""

from __future__ import annotations

import json
import subprocess
import sys

from harness.sim.simulation import Simulation

READER = """
import json, sys, cv2
cap = cv2.VideoCapture(sys.argv[1])
shapes, stds = [], []
for _ in range(int(sys.argv[2])):
    ok, img = cap.read()
    if not ok:
        break
    shapes.append(list(img.shape))
    stds.append(float(img.std()))
print(json.dumps({"opened": cap.isOpened(), "shapes": shapes, "stds": stds}))
"""
"""The reader: opens argv[1], reads up to argv[2] frames, prints what it got as JSON."""


def read_while_running(
    sim: Simulation, uri: str, frames: int, max_duration_s: float, timeout_s: float
) -> tuple[dict, str]:
    """Run ``sim`` paced at 4x until the reader ends (bounded in simulation time).

    Returns:
        The reader's JSON (``opened``, ``shapes``, ``stds``) and its stderr.
    """
    proc = subprocess.Popen(
        [sys.executable, "-c", READER, uri, str(frames)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # Paced so the reader sees a live camera.
        sim.run_paced(4.0, lambda: proc.poll() is not None, max_duration_s=max_duration_s)
        out, err = proc.communicate(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return json.loads(out.strip().splitlines()[-1]), err
