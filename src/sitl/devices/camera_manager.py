"""A vehicle's camera as a MAVLink component (MAV_COMP_ID_CAMERA), like PX4 SITL's Gazebo camera.

PX4 SITL's Gazebo camera manager is its own MAVLink node: system id of its vehicle, component
100, on PX4's onboard payload link (PX4 listens on UDP 14280+i and sends to 14030+i, with
forwarding on, so MAVSDK on 14540+i and a ground station on 14550 see the camera and reach it).
This module is that node for the simulated camera:

* :class:`CameraProtocol`: the camera protocol (MAVLink camera protocol v2), free of I/O. It
  sends HEARTBEAT (MAV_TYPE_CAMERA, MAV_AUTOPILOT_INVALID) at 1 Hz; answers MAV_CMD_REQUEST_MESSAGE
  (512) and the deprecated request commands MAVSDK falls back to when 512 is unsupported
  (521 CAMERA_INFORMATION, 522 CAMERA_SETTINGS, 525 STORAGE_INFORMATION, 527
  CAMERA_CAPTURE_STATUS, 2002 CAMERA_IMAGE_CAPTURED, 2504 VIDEO_STREAM_INFORMATION, 2505
  VIDEO_STREAM_STATUS); takes photos on MAV_CMD_IMAGE_START_CAPTURE (2000: one shot, or every
  param2 s for param3 shots, 0 = until IMAGE_STOP_CAPTURE 2001) and reports each with
  CAMERA_IMAGE_CAPTURED, geotagged with the pose the frame was rendered from. Every command gets
  a COMMAND_ACK from component 100; unknown ones MAV_RESULT_UNSUPPORTED. It needs
  no definition file (CAMERA_INFORMATION.cam_definition_uri is empty) and records no video
  (VIDEO_START_CAPTURE is unsupported; the live stream is the MJPEG server's).
* :class:`JpegStore`: where photos go (JPEG files in a directory; ``file://`` URLs) and the
  STORAGE_INFORMATION of that directory's file system.
* :class:`CameraManager`: the UDP adapter, polled on the simulation clock (no thread, so lockstep
  runs stay deterministic): binds the payload link's remote port and talks to the vehicle's
  payload listen port.

Units and frames: CAMERA_IMAGE_CAPTURED carries lat/lon in degE7, altitude AMSL and above the
ground plane (the world's origin altitude) in mm, and the camera's attitude in NED as a (w, x,
y, z) quaternion whose x axis is the optical axis (:func:`sitl.frames.camera_attitude_ned`).
Times come from the simulation clock: time_boot_ms = simulation time, time_utc = the run's Unix
start + simulation time of the frame's exposure.

Bad input: malformed frames, commands for other components, NaN parameters are counted or
answered (DENIED / UNSUPPORTED), never raised. A capture before any frame was rendered answers
CAMERA_IMAGE_CAPTURED with capture_result 0 (failure), no file and no position; its index is
still used, so that a client waiting for the image is told rather than left waiting.
"""

from __future__ import annotations

import errno
import logging
import math
import shutil
import socket
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl import frames
from sitl.sensors.camera import CameraFrame, CameraSpec

logger = logging.getLogger(__name__)

MAV_COMP_ID_CAMERA = mavlink2.MAV_COMP_ID_CAMERA
HEARTBEAT_INTERVAL_S = 1.0
SENSOR_WIDTH_MM = 6.17
"""Width of the simulated image sensor, mm (a 1/2.3" sensor, common in small drone cameras); the
focal length follows from it and the horizontal field of view, the height from the aspect."""
MAX_REMEMBERED_CAPTURES = 1000
"""CAMERA_IMAGE_CAPTURED messages kept for re-requests (MAVSDK asks again for missed ones)."""
MAX_FILE_URL_BYTES = 205
"""Size of CAMERA_IMAGE_CAPTURED.file_url."""
MAX_DATAGRAMS_PER_POLL = 64

ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
DENIED = mavlink2.MAV_RESULT_DENIED
UNSUPPORTED = mavlink2.MAV_RESULT_UNSUPPORTED

_DEPRECATED_REQUESTS = {
    mavlink2.MAV_CMD_REQUEST_CAMERA_INFORMATION: mavlink2.MAVLINK_MSG_ID_CAMERA_INFORMATION,
    mavlink2.MAV_CMD_REQUEST_CAMERA_SETTINGS: mavlink2.MAVLINK_MSG_ID_CAMERA_SETTINGS,
    mavlink2.MAV_CMD_REQUEST_STORAGE_INFORMATION: mavlink2.MAVLINK_MSG_ID_STORAGE_INFORMATION,
    mavlink2.MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS: mavlink2.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS,
    mavlink2.MAV_CMD_REQUEST_CAMERA_IMAGE_CAPTURE: mavlink2.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED,
    mavlink2.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION: (
        mavlink2.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION
    ),
    mavlink2.MAV_CMD_REQUEST_VIDEO_STREAM_STATUS: mavlink2.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS,
}
"""Deprecated request commands -> the message they ask for (their param1 plays the role of
REQUEST_MESSAGE's param2: storage id, image index or stream id; 1 = "request" for the others)."""
_PARAM1_IS_INDEX = frozenset(
    {
        mavlink2.MAV_CMD_REQUEST_STORAGE_INFORMATION,
        mavlink2.MAV_CMD_REQUEST_CAMERA_IMAGE_CAPTURE,
        mavlink2.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION,
        mavlink2.MAV_CMD_REQUEST_VIDEO_STREAM_STATUS,
    }
)

VIDEO_STREAM_ID = 1
VIDEO_STREAM_TYPE = mavlink2.VIDEO_STREAM_TYPE_TCP_MPEG
"""MAVLink has no stream type for MJPEG over HTTP; TCP_MPEG ("MPEG on TCP") is the closest: the
stream runs over TCP and is a sequence of compressed frames. The URI's ``http://`` scheme and the
stream name "MJPEG" say what it is; OpenCV opens the URI as it is."""
VIDEO_STREAM_ENCODING = mavlink2.VIDEO_STREAM_ENCODING_UNKNOWN
"""MAVLink's encodings are H.264 and H.265 only; MJPEG is "unknown"."""


@dataclass(frozen=True)
class StorageInfo:
    """Capacity of the camera's storage, MiB."""

    total_mib: float
    used_mib: float
    available_mib: float


class JpegStore:
    """Photos as ``IMG_0001.jpg``, ``IMG_0002.jpg``, ... (1-based names) in one directory.

    URLs are ``file://`` URIs of the absolute path (what a companion on the same machine opens);
    when that is longer than CAMERA_IMAGE_CAPTURED.file_url allows (205 bytes), the bare file
    name. The directory is created on the first photo.
    """

    def __init__(self, directory: Path, jpeg_quality: int = 90) -> None:
        self.directory = Path(directory)
        self._quality = int(jpeg_quality)

    def path(self, index: int) -> Path:
        """File of photo ``index`` (0-based)."""
        return self.directory / f"IMG_{index + 1:04d}.jpg"

    def save(self, frame: CameraFrame, index: int) -> str:
        """Encode the frame as JPEG (OpenCV) and write it; its URL, "" when writing failed."""
        path = self.path(index)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            bgr = cv2.cvtColor(np.ascontiguousarray(frame.rgb), cv2.COLOR_RGB2BGR)
            ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, self._quality])
            if not ok:
                return ""
            path.write_bytes(data.tobytes())
        except (OSError, cv2.error) as exc:
            logger.warning("camera: cannot write %s: %s", path, exc)
            return ""
        url = path.resolve().as_uri()
        return url if len(url.encode()) <= MAX_FILE_URL_BYTES else path.name

    def storage(self) -> StorageInfo | None:
        """Free and used space of the file system holding the directory."""
        where = self.directory
        while not where.exists() and where != where.parent:
            where = where.parent
        try:
            usage = shutil.disk_usage(where)
        except OSError:
            return None
        mib = 1024.0 * 1024.0
        return StorageInfo(usage.total / mib, usage.used / mib, usage.free / mib)


@dataclass
class CaptureStats:
    """Counters of what the camera did."""

    commands: int = 0
    ignored: int = 0
    """Commands for another system or component."""
    images: int = 0
    """CAMERA_IMAGE_CAPTURED sent for new photos (successful or not)."""
    failed_images: int = 0
    """Photos without a frame or that could not be written."""
    parse_errors: int = 0


class CameraProtocol:
    """The camera's MAVLink behaviour, without I/O: messages in, messages out.

    Args:
        spec: the camera (resolution, field of view, rate, mount).
        sysid: the vehicle's system id (the camera's too).
        origin: geodetic position of the world's ENU origin (geotags).
        epoch_start_s: Unix time at simulation t = 0, s.
        store: where photos go.
        stream_uri: the live stream's URL (None: no stream announced).
        compid: the camera's component id.
    """

    def __init__(
        self,
        spec: CameraSpec,
        sysid: int,
        origin: frames.GeodeticOrigin,
        epoch_start_s: float,
        store: JpegStore,
        stream_uri: str | None = None,
        compid: int = MAV_COMP_ID_CAMERA,
    ) -> None:
        if not 1 <= sysid <= 255 or not 1 <= compid <= 255:
            raise ValueError(f"sysid/compid must be 1..255, got {sysid}/{compid}")
        self.spec = spec
        self.sysid = sysid
        self.compid = compid
        self.origin = origin
        self.epoch_start_s = float(epoch_start_s)
        self.store = store
        self.stream_uri = stream_uri
        self.stats = CaptureStats()
        self.mode = mavlink2.CAMERA_MODE_IMAGE
        self._frame: CameraFrame | None = None
        self._next_heartbeat_s = 0.0
        self._image_count = 0
        self._captured: OrderedDict[int, mavlink2.MAVLink_camera_image_captured_message] = (
            OrderedDict()
        )
        self._last_sequence: int | None = None
        self._interval_s = 0.0
        self._remaining: int | None = None
        """Photos left in the running interval capture (None: until stopped)."""
        self._next_capture_s: float | None = None
        """When the running interval capture takes its next photo (None: none running)."""

    # --- inputs --------------------------------------------------------------------------------

    def on_frame(self, frame: CameraFrame) -> None:
        """The latest rendered image of this camera (photos use the latest at capture time)."""
        self._frame = frame

    def tick(self, now_s: float) -> list[mavlink2.MAVLink_message]:
        """Messages due at simulation time ``now_s``: heartbeat, interval photos."""
        out: list[mavlink2.MAVLink_message] = []
        if now_s >= self._next_heartbeat_s:
            self._next_heartbeat_s = now_s + HEARTBEAT_INTERVAL_S
            out.append(self.heartbeat())
        if self._next_capture_s is not None and now_s >= self._next_capture_s - 1e-9:
            out.append(self._capture(now_s))
            if self._remaining is not None:
                self._remaining -= 1
            if self._remaining is not None and self._remaining <= 0:
                self._next_capture_s = None
            else:
                self._next_capture_s += self._interval_s
        return out

    def handle(self, msg: mavlink2.MAVLink_message, now_s: float) -> list[mavlink2.MAVLink_message]:
        """Messages to send in answer to ``msg`` (commands only; the rest is ignored)."""
        if msg.get_msgId() not in (
            mavlink2.MAVLINK_MSG_ID_COMMAND_LONG,
            mavlink2.MAVLINK_MSG_ID_COMMAND_INT,
        ):
            return []
        if msg.target_system not in (0, self.sysid) or msg.target_component not in (
            0,
            self.compid,
        ):
            self.stats.ignored += 1
            return []
        self.stats.commands += 1
        params = [float(getattr(msg, f"param{k}")) for k in (1, 2, 3, 4)]
        replies: list[mavlink2.MAVLink_message] = []
        result = self._execute(int(msg.command), params, now_s, replies)
        ack = mavlink2.MAVLink_command_ack_message(
            command=msg.command,
            result=result,
            progress=0,
            result_param2=0,
            target_system=msg.get_srcSystem(),
            target_component=msg.get_srcComponent(),
        )
        return [ack, *replies]

    # --- commands ------------------------------------------------------------------------------

    def _execute(
        self, command: int, p: list[float], now_s: float, replies: list[mavlink2.MAVLink_message]
    ) -> int:
        if command == mavlink2.MAV_CMD_REQUEST_MESSAGE:
            if not math.isfinite(p[0]):
                return DENIED
            return self._request(int(p[0]), p[1], now_s, replies)
        if command in _DEPRECATED_REQUESTS:
            index = p[0] if command in _PARAM1_IS_INDEX else 0.0
            if command not in _PARAM1_IS_INDEX and p[0] == 0:
                return ACCEPTED  # param1 0: "do not send" in these commands
            return self._request(_DEPRECATED_REQUESTS[command], index, now_s, replies)
        if command == mavlink2.MAV_CMD_SET_CAMERA_MODE:
            if p[1] not in (mavlink2.CAMERA_MODE_IMAGE, mavlink2.CAMERA_MODE_VIDEO):
                return DENIED
            self.mode = int(p[1])
            replies.append(self.camera_settings(now_s))
            return ACCEPTED
        if command == mavlink2.MAV_CMD_IMAGE_START_CAPTURE:
            return self._start_capture(p[1], p[2], p[3], now_s, replies)
        if command == mavlink2.MAV_CMD_IMAGE_STOP_CAPTURE:
            self._next_capture_s = None
            return ACCEPTED
        if command in (
            mavlink2.MAV_CMD_VIDEO_START_STREAMING,
            mavlink2.MAV_CMD_VIDEO_STOP_STREAMING,
        ):
            # The MJPEG stream serves whoever connects; nothing to start or stop.
            return ACCEPTED if self.stream_uri else UNSUPPORTED
        return UNSUPPORTED

    def _request(
        self, msg_id: int, index: float, now_s: float, replies: list[mavlink2.MAVLink_message]
    ) -> int:
        """REQUEST_MESSAGE ``msg_id`` (``index``: REQUEST_MESSAGE's param2)."""
        if not math.isfinite(index):
            index = 0.0
        if msg_id == mavlink2.MAVLINK_MSG_ID_CAMERA_INFORMATION:
            replies.append(self.camera_information(now_s))
        elif msg_id == mavlink2.MAVLINK_MSG_ID_CAMERA_SETTINGS:
            replies.append(self.camera_settings(now_s))
        elif msg_id == mavlink2.MAVLINK_MSG_ID_STORAGE_INFORMATION:
            if index not in (0.0, 1.0):
                return DENIED
            replies.append(self.storage_information(now_s))
        elif msg_id == mavlink2.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS:
            replies.append(self.capture_status(now_s))
        elif msg_id == mavlink2.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED:
            captured = self._captured.get(int(index))
            if captured is None:
                return DENIED
            replies.append(captured)
        elif msg_id in (
            mavlink2.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION,
            mavlink2.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS,
        ):
            if not self.stream_uri or index not in (0.0, VIDEO_STREAM_ID):
                return DENIED
            if msg_id == mavlink2.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION:
                replies.append(self.video_stream_information())
            else:
                replies.append(self.video_stream_status())
        else:
            return DENIED
        return ACCEPTED

    def _start_capture(
        self,
        interval_s: float,
        count: float,
        sequence: float,
        now_s: float,
        replies: list[mavlink2.MAVLink_message],
    ) -> int:
        """IMAGE_START_CAPTURE: one photo now, or a series every ``interval_s``.

        param2 interval s, param3 count (0: until stopped), param4 the capture sequence number
        of a single shot (a repeated number is a retransmission: ACKed, no second photo).
        """
        if not math.isfinite(count) or count < 0:
            return DENIED
        if count == 1:
            if math.isfinite(sequence) and sequence > 0:
                if self._last_sequence == int(sequence):
                    return ACCEPTED  # the same shot again: the client missed our ACK
                self._last_sequence = int(sequence)
            replies.append(self._capture(now_s))
            return ACCEPTED
        if not (math.isfinite(interval_s) and interval_s > 0):
            return DENIED
        self._interval_s = max(interval_s, 1.0 / self.spec.rate_hz)
        self._remaining = None if count == 0 else int(count)
        self._next_capture_s = now_s
        return ACCEPTED

    def _capture(self, now_s: float) -> mavlink2.MAVLink_camera_image_captured_message:
        """Take photo number ``image_count`` from the latest frame; its CAMERA_IMAGE_CAPTURED."""
        index = self._image_count
        self._image_count += 1
        frame = self._frame
        url = self.store.save(frame, index) if frame is not None else ""
        if frame is None:
            lat = lon = alt_mm = rel_mm = 0
            q = [1.0, 0.0, 0.0, 0.0]
            stamp_s = now_s
            logger.info("camera of system %d: photo %d before the first frame", self.sysid, index)
        else:
            lat_deg, lon_deg, alt_m = frames.enu_to_geodetic(frame.position_enu_m, self.origin)
            lat, lon = round(float(lat_deg) * 1e7), round(float(lon_deg) * 1e7)
            alt_mm = round(float(alt_m) * 1e3)
            rel_mm = round(float(frame.position_enu_m[2]) * 1e3)
            q = [
                float(v)
                for v in frames.camera_attitude_ned(
                    frame.vehicle_quaternion_xyzw, frame.spec.pitch_deg, frame.spec.yaw_deg
                )
            ]
            stamp_s = frame.time_s
        ok = bool(url)
        self.stats.images += 1
        if not ok:
            self.stats.failed_images += 1
        message = mavlink2.MAVLink_camera_image_captured_message(
            time_boot_ms=_boot_ms(stamp_s),
            time_utc=max(0, round((self.epoch_start_s + stamp_s) * 1e6)),
            camera_id=0,
            lat=lat,
            lon=lon,
            alt=alt_mm,
            relative_alt=rel_mm,
            q=q,
            image_index=index,
            capture_result=1 if ok else 0,
            file_url=url.encode(),
        )
        self._captured[index] = message
        while len(self._captured) > MAX_REMEMBERED_CAPTURES:
            self._captured.popitem(last=False)
        return message

    # --- messages ------------------------------------------------------------------------------

    def heartbeat(self) -> mavlink2.MAVLink_heartbeat_message:
        """HEARTBEAT of a camera (MAVSDK and QGroundControl discover cameras by it)."""
        return mavlink2.MAVLink_heartbeat_message(
            type=mavlink2.MAV_TYPE_CAMERA,
            autopilot=mavlink2.MAV_AUTOPILOT_INVALID,
            base_mode=0,
            custom_mode=0,
            system_status=mavlink2.MAV_STATE_ACTIVE,
            mavlink_version=3,
        )

    def optics_mm(self) -> tuple[float, float, float]:
        """(focal length, sensor width, sensor height), mm, of the spec's field of view."""
        spec = self.spec
        focal = SENSOR_WIDTH_MM / (2.0 * math.tan(math.radians(spec.hfov_deg) / 2.0))
        return focal, SENSOR_WIDTH_MM, SENSOR_WIDTH_MM * spec.height_px / spec.width_px

    def camera_information(self, now_s: float) -> mavlink2.MAVLink_camera_information_message:
        """CAMERA_INFORMATION: what the camera is and can do (no definition file)."""
        focal, width_mm, height_mm = self.optics_mm()
        flags = mavlink2.CAMERA_CAP_FLAGS_CAPTURE_IMAGE
        if self.stream_uri:
            flags |= mavlink2.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM
        return mavlink2.MAVLink_camera_information_message(
            time_boot_ms=_boot_ms(now_s),
            vendor_name=_bytes32("swarmsitl"),
            model_name=_bytes32("PyBullet RGB camera"),
            firmware_version=0,
            focal_length=focal,
            sensor_size_h=width_mm,
            sensor_size_v=height_mm,
            resolution_h=self.spec.width_px,
            resolution_v=self.spec.height_px,
            lens_id=0,
            flags=flags,
            cam_definition_version=0,
            cam_definition_uri=b"",
            gimbal_device_id=0,
            camera_device_id=0,
        )

    def camera_settings(self, now_s: float) -> mavlink2.MAVLink_camera_settings_message:
        """CAMERA_SETTINGS: the mode (image or video); no zoom or focus (NaN)."""
        return mavlink2.MAVLink_camera_settings_message(
            time_boot_ms=_boot_ms(now_s),
            mode_id=self.mode,
            zoomLevel=math.nan,
            focusLevel=math.nan,
            camera_device_id=0,
        )

    def storage_information(self, now_s: float) -> mavlink2.MAVLink_storage_information_message:
        """STORAGE_INFORMATION of the photo directory's file system."""
        info = self.store.storage()
        status = (
            mavlink2.STORAGE_STATUS_READY if info is not None else mavlink2.STORAGE_STATUS_EMPTY
        )
        info = info if info is not None else StorageInfo(0.0, 0.0, 0.0)
        return mavlink2.MAVLink_storage_information_message(
            time_boot_ms=_boot_ms(now_s),
            storage_id=1,
            storage_count=1,
            status=status,
            total_capacity=info.total_mib,
            used_capacity=info.used_mib,
            available_capacity=info.available_mib,
            read_speed=math.nan,
            write_speed=math.nan,
            type=mavlink2.STORAGE_TYPE_OTHER,
            name=b"run directory",
            storage_usage=mavlink2.STORAGE_USAGE_FLAG_SET | mavlink2.STORAGE_USAGE_FLAG_PHOTO,
        )

    def capture_status(self, now_s: float) -> mavlink2.MAVLink_camera_capture_status_message:
        """CAMERA_CAPTURE_STATUS: interval capture running or idle, photos taken."""
        running = self._next_capture_s is not None
        info = self.store.storage()
        return mavlink2.MAVLink_camera_capture_status_message(
            time_boot_ms=_boot_ms(now_s),
            image_status=3 if running else 0,  # 3: interval set and capture in progress
            video_status=0,
            image_interval=self._interval_s if running else 0.0,
            recording_time_ms=0,
            available_capacity=info.available_mib if info is not None else math.nan,
            image_count=self._image_count,
            camera_device_id=0,
        )

    def video_stream_information(self) -> mavlink2.MAVLink_video_stream_information_message:
        """VIDEO_STREAM_INFORMATION of the MJPEG stream (see VIDEO_STREAM_TYPE)."""
        spec = self.spec
        return mavlink2.MAVLink_video_stream_information_message(
            stream_id=VIDEO_STREAM_ID,
            count=1,
            type=VIDEO_STREAM_TYPE,
            flags=mavlink2.VIDEO_STREAM_STATUS_FLAGS_RUNNING,
            framerate=float(spec.rate_hz),
            resolution_h=spec.width_px,
            resolution_v=spec.height_px,
            bitrate=0,
            rotation=0,
            hfov=round(spec.hfov_deg),
            name=b"MJPEG",
            uri=(self.stream_uri or "").encode(),
            encoding=VIDEO_STREAM_ENCODING,
            camera_device_id=0,
        )

    def video_stream_status(self) -> mavlink2.MAVLink_video_stream_status_message:
        """VIDEO_STREAM_STATUS of the MJPEG stream."""
        spec = self.spec
        return mavlink2.MAVLink_video_stream_status_message(
            stream_id=VIDEO_STREAM_ID,
            flags=mavlink2.VIDEO_STREAM_STATUS_FLAGS_RUNNING,
            framerate=float(spec.rate_hz),
            resolution_h=spec.width_px,
            resolution_v=spec.height_px,
            bitrate=0,
            rotation=0,
            hfov=round(spec.hfov_deg),
            camera_device_id=0,
        )


def _boot_ms(t_s: float) -> int:
    return max(0, round(t_s * 1000.0)) & 0xFFFFFFFF


def _bytes32(text: str) -> list[int]:
    """A uint8[32] field holding ``text`` (NUL-padded)."""
    raw = text.encode()[:32]
    return list(raw + bytes(32 - len(raw)))


class _UdpWriter:
    """pymavlink's output file: each packed frame goes to the vehicle in one datagram."""

    def __init__(self, sock: socket.socket, address: tuple[str, int]) -> None:
        self.sock = sock
        self.address = address
        self.send_errors = 0

    def write(self, data: bytes) -> None:
        try:
            self.sock.sendto(data, self.address)
        except OSError:
            self.send_errors += 1


_SIGNING_EPOCH_UNIX_S = 1_420_070_400
"""2015-01-01 00:00 UTC: MAVLink 2 signing timestamps count 10 us units from it."""


class CameraManager:
    """The camera's MAVLink node on UDP: :class:`CameraProtocol` on the payload link.

    Args:
        protocol: the camera's behaviour.
        bind_addr: address to bind (the vehicle's).
        port: UDP port to bind (PX4 SITL: 14030 + i, the payload link's remote port).
        vehicle_port: the vehicle's payload link port to send to (PX4 SITL: 14280 + i).
        signing_key: the vehicle's MAVLink 2 signing key (32 bytes): sign every frame and
            accept only signed ones (pymavlink's signing, link id 0, timestamps from the wall
            clock as the MAVLink spec asks); None: no signing.

    Raises:
        OSError: ``port`` is taken (the message names it).
    """

    def __init__(
        self,
        protocol: CameraProtocol,
        bind_addr: str,
        port: int,
        vehicle_port: int,
        signing_key: bytes | None = None,
    ) -> None:
        self.protocol = protocol
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.bind((bind_addr, port))
        except OSError as exc:
            sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise OSError(
                    errno.EADDRINUSE,
                    f"UDP {bind_addr}:{port} (camera of system {protocol.sysid}) is already in "
                    "use (a PX4 SITL camera or another simulation?)",
                ) from exc
            raise
        sock.setblocking(False)
        self._sock: socket.socket | None = sock
        self._writer = _UdpWriter(sock, (bind_addr, vehicle_port))
        self._mav = mavlink2.MAVLink(
            self._writer, srcSystem=protocol.sysid, srcComponent=protocol.compid
        )
        self._mav.robust_parsing = True
        if signing_key is not None:
            signing = self._mav.signing
            signing.secret_key = signing_key
            signing.sign_outgoing = True
            signing.timestamp = int((time.time() - _SIGNING_EPOCH_UNIX_S) * 100_000)

    @property
    def local_address(self) -> tuple[str, int]:
        """(address, port) the camera's socket is bound to."""
        if self._sock is None:
            raise RuntimeError("camera manager is closed")
        host, port = self._sock.getsockname()[:2]
        return (host, port)

    def on_frame(self, frame: CameraFrame) -> None:
        """A new rendered frame of this camera."""
        self.protocol.on_frame(frame)

    def fileno(self) -> int:
        """File descriptor of the socket, for a readiness poll of many sockets at once."""
        if self._sock is None:
            raise RuntimeError("camera manager is closed")
        return self._sock.fileno()

    def poll(self, now_s: float, receive: bool = True) -> None:
        """Handle received commands, then send what is due at simulation time ``now_s``.

        ``receive=False`` skips reading the socket (the caller knows it holds nothing).
        """
        sock = self._sock
        if sock is None:
            return
        protocol = self.protocol
        for _ in range(MAX_DATAGRAMS_PER_POLL if receive else 0):
            try:
                data, _address = sock.recvfrom(65535)
            except BlockingIOError:
                break
            except OSError:
                break
            for msg in self._parse(data):
                for reply in protocol.handle(msg, now_s):
                    self._send(reply)
        for message in protocol.tick(now_s):
            self._send(message)

    def _parse(self, data: bytes) -> list[mavlink2.MAVLink_message]:
        try:
            msgs = self._mav.parse_buffer(data) or []
        except Exception:  # pymavlink raises assorted errors on garbage
            self.protocol.stats.parse_errors += 1
            msgs = []
        if self._mav.buf_len() > 0:  # a frame cut short: drop it
            self.protocol.stats.parse_errors += 1
            self._mav.buf = bytearray()
            self._mav.buf_index = 0
            self._mav.expected_length = mavlink2.HEADER_LEN_V1 + 2
        good = []
        for msg in msgs:
            if msg.get_msgId() < 0:  # BAD_DATA / UNKNOWN
                self.protocol.stats.parse_errors += 1
            else:
                good.append(msg)
        return good

    def _send(self, message: mavlink2.MAVLink_message) -> None:
        try:
            self._mav.send(message)
        except Exception:
            logger.exception("camera: cannot pack %s", message.get_type())

    def close(self) -> None:
        """Close the socket. Safe to call twice."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None
