"""A camera's video stream as a Pi receives it: MJPEG over HTTP, which ``cv2.VideoCapture`` opens.

``GET /video.mjpg`` answers ``multipart/x-mixed-replace; boundary=frame``: one JPEG per part, each
with its Content-Type and Content-Length, as IP cameras and ``mjpg-streamer`` serve it.
``GET /snapshot.jpg`` answers the latest frame as one JPEG. The pip OpenCV wheels
(opencv-python, opencv-python-headless) open ``http://host:port/video.mjpg`` with their bundled
FFmpeg and need no system package; RTP/UDP H.264 (PX4's Gazebo camera on UDP 5600) would need an
SDP file or GStreamer, and RTSP a separate server.

Cost and isolation: ``publish`` (the simulation thread) only swaps a reference and wakes the
client threads; a frame is JPEG-encoded only when a client asks for it, once however many
clients read it. Each client thread always sends the newest frame (a slow reader skips frames,
never queues them). A client that stops reading or vanishes times out (``send_timeout_s``) and
its thread ends; at most ``max_clients`` streams run at once (more get 503). ``close`` ends every
thread promptly.
"""

from __future__ import annotations

import contextlib
import logging
import socket
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np

from sitl.sensors.camera import CameraFrame

log = logging.getLogger(__name__)

STREAM_PATH = "/video.mjpg"
"""Path of the MJPEG stream."""
SNAPSHOT_PATH = "/snapshot.jpg"
"""Path of the single-JPEG snapshot of the latest frame."""
BOUNDARY = "frame"
"""Multipart boundary between the JPEGs of the stream."""


class _Latest:
    """The newest frame and, once someone asked for it, its JPEG (shared by all clients)."""

    def __init__(self, jpeg_quality: int) -> None:
        self.cond = threading.Condition()
        self.seq = 0
        """Number of frames published so far."""
        self.rgb: np.ndarray | None = None
        self.closed = False
        self._quality = [int(cv2.IMWRITE_JPEG_QUALITY), int(jpeg_quality)]
        self._encode_lock = threading.Lock()
        self._jpeg_seq = -1
        self._jpeg = b""

    def jpeg(self, seq: int, rgb: np.ndarray) -> bytes:
        """The JPEG of frame ``seq`` or a newer one (encoded once, by the first thread asking)."""
        with self._encode_lock:
            if self._jpeg_seq < seq:
                ok, buffer = cv2.imencode(".jpg", rgb[:, :, ::-1], self._quality)  # RGB -> BGR
                if not ok:
                    raise RuntimeError("JPEG encoding failed")
                self._jpeg, self._jpeg_seq = buffer.tobytes(), seq
            return self._jpeg

    def wait_newer(self, seen: int, timeout_s: float) -> tuple[int, np.ndarray | None]:
        """Block until a frame newer than ``seen`` exists (or timeout/close): (seq, rgb)."""
        with self.cond:
            if self.seq <= seen and not self.closed:
                self.cond.wait(timeout_s)
            return self.seq, self.rgb


class _HttpServer(ThreadingHTTPServer):
    daemon_threads = True
    block_on_close = False  # MjpegServer.close joins the client threads itself, with a timeout
    owner: MjpegServer

    def process_request(self, request: socket.socket, client_address: object) -> None:
        """Start the client's thread, known to the owner before it runs.

        So ``close`` joins it whatever point it has reached, the socket shutdown after
        ``finish`` included.
        """
        thread = threading.Thread(
            target=self.process_request_thread, args=(request, client_address), daemon=True
        )
        with self.owner._clients_lock:
            self.owner._threads = {t for t in self.owner._threads if t.is_alive()}
            self.owner._threads.add(thread)
        thread.start()


class _Handler(BaseHTTPRequestHandler):
    server: _HttpServer
    server_version = "swarmsitl-mjpeg/1"

    def setup(self) -> None:
        owner = self.server.owner
        self.timeout = owner.send_timeout_s  # applies to every recv and send
        super().setup()

    def log_message(self, format: str, *args: object) -> None:
        log.debug("mjpeg %s: " + format, self.client_address[0], *args)

    def do_GET(self) -> None:
        """Serve the stream or a snapshot."""
        path = self.path.split("?", 1)[0]
        owner = self.server.owner
        if path == STREAM_PATH:
            owner._stream(self)
        elif path == SNAPSHOT_PATH:
            owner._snapshot(self)
        else:
            self.send_error(HTTPStatus.NOT_FOUND, f"paths: {STREAM_PATH}, {SNAPSHOT_PATH}")


class MjpegServer:
    """One camera's MJPEG-over-HTTP server on ``bind_addr:port`` (port 0: the OS picks one)."""

    def __init__(
        self,
        bind_addr: str = "127.0.0.1",
        port: int = 0,
        jpeg_quality: int = 80,
        max_clients: int = 8,
        send_timeout_s: float = 5.0,
    ) -> None:
        if not 1 <= jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be in 1..100, got {jpeg_quality}")
        if max_clients < 1:
            raise ValueError(f"max_clients must be >= 1, got {max_clients}")
        if not send_timeout_s > 0.0:
            raise ValueError(f"send_timeout_s must be positive, got {send_timeout_s}")
        self.max_clients = max_clients
        """Streams served at once; more clients get 503 Service Unavailable."""
        self.send_timeout_s = float(send_timeout_s)
        """A client that neither sends its request nor reads for this long is dropped, s."""
        self._latest = _Latest(jpeg_quality)
        self._clients = 0
        self._clients_lock = threading.Lock()
        self._sockets: set[socket.socket] = set()
        self._threads: set[threading.Thread] = set()
        self._httpd = _HttpServer((bind_addr, port), _Handler)
        self._httpd.owner = self
        self._thread = threading.Thread(
            target=self._httpd.serve_forever,
            kwargs={"poll_interval": 0.1},
            name=f"mjpeg-{self.port}",
            daemon=True,
        )
        self._thread.start()

    @property
    def port(self) -> int:
        """TCP port the server listens on."""
        return int(self._httpd.server_address[1])

    @property
    def uri(self) -> str:
        """The stream's URL, e.g. ``http://127.0.0.1:5600/video.mjpg`` (cv2.VideoCapture(uri))."""
        host = str(self._httpd.server_address[0])
        if host in ("0.0.0.0", ""):
            host = "127.0.0.1"
        elif ":" in host:
            host = f"[{host}]"
        return f"http://{host}:{self.port}{STREAM_PATH}"

    @property
    def snapshot_uri(self) -> str:
        """URL of the latest frame as one JPEG."""
        return self.uri.removesuffix(STREAM_PATH) + SNAPSHOT_PATH

    @property
    def clients(self) -> int:
        """Number of clients reading the stream now."""
        return self._clients

    @property
    def threads(self) -> int:
        """Client threads alive now (streams, snapshots, connections not yet answered)."""
        with self._clients_lock:
            return sum(thread.is_alive() for thread in self._threads)

    @property
    def frames_published(self) -> int:
        """Frames handed to ``publish`` so far."""
        return self._latest.seq

    def publish(self, frame: CameraFrame) -> None:
        """Make ``frame`` the newest one (never blocks; do not modify ``frame.rgb`` afterwards)."""
        latest = self._latest
        with latest.cond:
            latest.rgb = frame.rgb
            latest.seq += 1
            latest.cond.notify_all()

    def close(self) -> None:
        """Stop serving: end the accept loop and every client thread (idempotent)."""
        latest = self._latest
        with latest.cond:
            if latest.closed:
                return
            latest.closed = True
            latest.cond.notify_all()
        self._httpd.shutdown()
        with self._clients_lock:
            sockets = list(self._sockets)
        for sock in sockets:  # unblocks a thread stuck sending to a client that does not read
            with contextlib.suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
        self._httpd.server_close()
        with self._clients_lock:
            threads = list(self._threads)
        for thread in threads:
            thread.join(timeout=1.0)
        self._thread.join(timeout=1.0)

    def __enter__(self) -> MjpegServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- client threads -----------------------------------------------------------------------

    def _snapshot(self, handler: _Handler) -> None:
        latest = self._latest
        seq, rgb = latest.seq, latest.rgb
        if rgb is None:
            handler.send_error(HTTPStatus.SERVICE_UNAVAILABLE, "no frame yet")
            return
        body = latest.jpeg(seq, rgb)
        handler.send_response(HTTPStatus.OK)
        handler.send_header("Content-Type", "image/jpeg")
        handler.send_header("Content-Length", str(len(body)))
        handler.send_header("Cache-Control", "no-cache")
        handler.end_headers()
        handler.wfile.write(body)

    def _stream(self, handler: _Handler) -> None:
        with self._clients_lock:
            if self._clients >= self.max_clients:
                full = True
            else:
                full = False
                self._clients += 1
                self._sockets.add(handler.connection)
        if full:
            handler.send_error(HTTPStatus.SERVICE_UNAVAILABLE, "too many clients")
            return
        try:
            handler.send_response(HTTPStatus.OK)
            handler.send_header("Content-Type", f"multipart/x-mixed-replace; boundary={BOUNDARY}")
            handler.send_header("Cache-Control", "no-cache, no-store")
            handler.send_header("Pragma", "no-cache")
            handler.send_header("Connection", "close")
            handler.end_headers()
            self._send_frames(handler)
        except (OSError, ValueError) as exc:  # the client went away, stalled, or we closed
            log.debug("mjpeg client %s done: %s", handler.client_address[0], exc)
        finally:
            handler.close_connection = True
            with self._clients_lock:
                self._clients -= 1
                self._sockets.discard(handler.connection)

    def _send_frames(self, handler: _Handler) -> None:
        latest = self._latest
        seen = 0
        while not latest.closed:
            seq, rgb = latest.wait_newer(seen, timeout_s=0.5)
            if seq <= seen or rgb is None:
                continue
            seen = seq
            jpeg = latest.jpeg(seq, rgb)
            head = (
                f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n\r\n"
            ).encode("ascii")
            handler.wfile.write(head + jpeg + b"\r\n")
            handler.wfile.flush()
