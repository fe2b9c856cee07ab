"""MJPEG-over-HTTP camera stream: OpenCV in another process reads it; bad clients cost nothing."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest

from sitl.devices import mjpeg_server
from sitl.devices.mjpeg_server import MjpegServer
from sitl.sensors.camera import CameraFrame, CameraSpec

pytestmark = pytest.mark.process

READER = """
import json, sys, cv2
cap = cv2.VideoCapture(sys.argv[1])
out = {"opened": cap.isOpened(), "backend": cap.getBackendName() if cap.isOpened() else ""}
frames = []
for _ in range(int(sys.argv[2])):
    ok, img = cap.read()
    if not ok:
        break
    h, w = img.shape[:2]
    frames.append({"shape": list(img.shape), "left_bgr": img[:, : w // 2].mean((0, 1)).tolist(),
                   "right_bgr": img[:, w // 2 :].mean((0, 1)).tolist(), "std": float(img.std())})
out["frames"] = frames
cap.release()
print(json.dumps(out))
"""


def _frame(k: int, width: int = 320, height: int = 240) -> CameraFrame:
    """Left half red, right half blue, and a moving white column (RGB)."""
    rgb = np.zeros((height, width, 3), np.uint8)
    rgb[:, : width // 2, 0] = 220
    rgb[:, width // 2 :, 2] = 220
    rgb[:, k % width] = 255
    spec = CameraSpec(width_px=width, height_px=height)
    return CameraFrame(0, k * 0.1, rgb, np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), spec)


def _publish_until(server: MjpegServer, done: callable, limit: int = 4000) -> int:
    """Publish frames (paced a little, like a camera) until ``done()``; the count published."""
    k = 0
    while not done() and k < limit:
        server.publish(_frame(k))
        k += 1
        time.sleep(0.01)
    return k


def test_opencv_in_another_process_reads_the_stream():
    """cv2.VideoCapture(uri) (pip wheel, FFmpeg) reads frames of the right size and colours."""
    # Port 0: the OS picks a free port (concurrent test runs never collide).
    with MjpegServer("127.0.0.1", 0) as server:
        assert server.uri == f"http://127.0.0.1:{server.port}/video.mjpg"
        proc = subprocess.Popen(
            [sys.executable, "-c", READER, server.uri, "5"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            _publish_until(server, lambda: proc.poll() is not None)
            out, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    assert out.strip(), f"the reader printed nothing; stderr:\n{err}"
    result = json.loads(out.strip().splitlines()[-1])
    assert result["opened"], err
    assert len(result["frames"]) == 5, (result, err)
    for frame in result["frames"]:
        assert frame["shape"] == [240, 320, 3]
        left_b, _, left_r = frame["left_bgr"]
        right_b, _, right_r = frame["right_bgr"]
        assert left_r > 180 > 60 > left_b  # red on the left: RGB -> BGR was right
        assert right_b > 180 > 60 > right_r


def test_snapshot_serves_the_latest_frame():
    with MjpegServer("127.0.0.1", 0) as server:
        with pytest.raises(urllib.error.HTTPError) as error:
            urllib.request.urlopen(server.snapshot_uri, timeout=10)
        assert error.value.code == 503
        server.publish(_frame(0))
        server.publish(_frame(7))
        with urllib.request.urlopen(server.snapshot_uri, timeout=10) as reply:
            assert reply.headers["Content-Type"] == "image/jpeg"
            data = reply.read()
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        assert img.shape == (240, 320, 3)
        assert img[:, 7].min() > 200  # the white column of frame 7
        with pytest.raises(urllib.error.HTTPError) as error:
            urllib.request.urlopen(server.uri.replace("video.mjpg", "nope"), timeout=10)
        assert error.value.code == 404


def test_nothing_is_encoded_without_a_client(monkeypatch):
    """Publishing with nobody connected never runs the JPEG encoder."""
    calls = []
    real = cv2.imencode
    monkeypatch.setattr(
        mjpeg_server.cv2, "imencode", lambda *a, **k: calls.append(1) or real(*a, **k)
    )
    with MjpegServer("127.0.0.1", 0) as server:
        for k in range(50):
            server.publish(_frame(k))
        assert server.frames_published == 50
        assert calls == []
        urllib.request.urlopen(server.snapshot_uri, timeout=10).read()
        assert len(calls) == 1


def _read_parts(uri: str, n: int) -> list[bytes]:
    """Read n multipart JPEG parts with a plain HTTP client."""
    parts = []
    with urllib.request.urlopen(uri, timeout=10) as reply:
        assert reply.headers["Content-Type"].startswith("multipart/x-mixed-replace; boundary=")
        while len(parts) < n:
            line = reply.readline()
            if line.startswith(b"Content-Length:"):
                length = int(line.split(b":")[1])
                reply.readline()  # blank line
                parts.append(reply.read(length))
    return parts


def test_bad_clients_never_block_publish_and_their_threads_end():
    """A client that sends nothing, one that never reads and one that vanishes: publish goes on
    (all frames published), a new client is served, and the bad clients' threads end."""
    with MjpegServer("127.0.0.1", 0, send_timeout_s=1.0) as server:
        silent = socket.create_connection(("127.0.0.1", server.port))  # never sends a request
        stalled = socket.create_connection(("127.0.0.1", server.port))
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.sendall(b"GET /video.mjpg HTTP/1.1\r\nHost: x\r\n\r\n")  # ... and never reads
        vanished = socket.create_connection(("127.0.0.1", server.port))
        vanished.sendall(b"GET /video.mjpg HTTP/1.1\r\nHost: x\r\n\r\n")
        vanished.close()
        # Large incompressible frames fill the stalled client's socket buffers quickly.
        rng = np.random.default_rng(0)
        noise = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
        spec = CameraSpec(width_px=640, height_px=480)
        for k in range(200):
            frame = CameraFrame(0, k * 0.1, noise, np.zeros(3), np.array([0, 0, 0, 1.0]), spec)
            server.publish(frame)
            time.sleep(0.005)
        assert server.frames_published == 200
        # A new client is served meanwhile.
        reader = threading.Thread(target=lambda: box.append(_read_parts(server.uri, 2)))
        box: list = []
        reader.start()
        _publish_until(server, lambda: not reader.is_alive())
        reader.join(timeout=30)
        assert len(box) == 1 and all(part[:2] == b"\xff\xd8" for part in box[0])  # JPEG SOI
        # The silent and stalled clients are dropped after send_timeout_s; their threads end.
        deadline = time.monotonic() + 30.0
        while server.threads > 0 and time.monotonic() < deadline:
            server.publish(_frame(0))
            time.sleep(0.05)
        assert server.threads == 0
        assert server.clients == 0
        silent.close()
        stalled.close()


def test_max_clients_and_close_end_every_thread():
    before = set(threading.enumerate())
    server = MjpegServer("127.0.0.1", 0, max_clients=1)
    first = urllib.request.urlopen(server.uri, timeout=10)
    deadline = time.monotonic() + 10.0
    while server.clients < 1 and time.monotonic() < deadline:
        time.sleep(0.01)
    with pytest.raises(urllib.error.HTTPError) as error:
        urllib.request.urlopen(server.uri, timeout=10)
    assert error.value.code == 503
    server.close()
    first.close()
    assert server.threads == 0
    assert [t for t in threading.enumerate() if t not in before and t.is_alive()] == []
    # The port is free again.
    MjpegServer("127.0.0.1", server.port).close()


def test_port_zero_lets_the_os_pick():
    with MjpegServer("127.0.0.1", 0) as server:
        assert server.port > 0
        assert server.uri.endswith(f":{server.port}/video.mjpg")
