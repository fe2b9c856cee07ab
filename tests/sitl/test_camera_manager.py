"""The MAVLink camera component: requests -> replies, photos and their geotags, bad input."""

from __future__ import annotations

import math
import shutil
import socket
import time

import cv2
import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from sitl import frames
from sitl.devices.camera_manager import CameraManager, CameraProtocol, JpegStore
from sitl.sensors.camera import CameraFrame, CameraSpec

pytestmark = pytest.mark.sockets

ORIGIN = frames.GeodeticOrigin(47.397742, 8.545594, 488.0)
EPOCH_S = 1_700_000_000.0
URI = "http://127.0.0.1:5600/video.mjpg"  # port-literal: PX4's video port, only reported
EARTH_M_PER_DEG = 111_132.0  # metres per degree of latitude near 47 deg (WGS-84 meridian arc)
ACCEPTED = mavlink2.MAV_RESULT_ACCEPTED
DENIED = mavlink2.MAV_RESULT_DENIED
UNSUPPORTED = mavlink2.MAV_RESULT_UNSUPPORTED


def _received(msg: mavlink2.MAVLink_message, src=(245, 190)) -> mavlink2.MAVLink_message:
    mav = mavlink2.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    return mav.parse_char(msg.pack(mav))


def _cmd(command, *params, target=(1, 100), src=(245, 190)):
    padded = list(params) + [math.nan] * (7 - len(params))
    return _received(mavlink2.MAVLink_command_long_message(*target, command, 0, *padded), src)


def _frame(t_s=2.0, pos=(0.0, 0.0, 10.0), q_xyzw=(0.0, 0.0, 0.0, 1.0), spec=None, shade=90):
    spec = spec or CameraSpec()
    rgb = np.full((spec.height_px, spec.width_px, 3), shade, np.uint8)
    rgb[:, : spec.width_px // 2, 0] = 250  # left half red: the JPEG keeps the channel order
    return CameraFrame(0, t_s, rgb, np.array(pos, float), np.array(q_xyzw, float), spec)


@pytest.fixture
def camera(tmp_path):
    return CameraProtocol(
        CameraSpec(width_px=320, height_px=240, hfov_deg=80.0, rate_hz=10.0),
        sysid=1,
        origin=ORIGIN,
        epoch_start_s=EPOCH_S,
        store=JpegStore(tmp_path / "vehicle1" / "camera"),
        stream_uri=URI,
    )


def _ack_and(replies, command, result=ACCEPTED):
    ack, *rest = replies
    assert ack.get_type() == "COMMAND_ACK"
    assert (ack.command, ack.result) == (command, result)
    assert (ack.target_system, ack.target_component) == (245, 190)
    return rest


def test_heartbeat_once_a_second_as_a_camera(camera):
    beats = [m for t in np.arange(0.0, 3.0, 0.004) for m in camera.tick(float(t))]
    assert len(beats) == 3
    assert all(b.get_type() == "HEARTBEAT" for b in beats)
    assert (beats[0].type, beats[0].autopilot) == (
        mavlink2.MAV_TYPE_CAMERA,
        mavlink2.MAV_AUTOPILOT_INVALID,
    )


def test_camera_information_describes_the_spec_optics(camera):
    (info,) = _ack_and(camera.handle(_cmd(512, 259), 1.5), 512)
    assert info.get_type() == "CAMERA_INFORMATION"
    assert (info.resolution_h, info.resolution_v) == (320, 240)
    hfov = math.degrees(2.0 * math.atan(info.sensor_size_h / (2.0 * info.focal_length)))
    assert hfov == pytest.approx(80.0, abs=0.01)
    vfov = math.degrees(2.0 * math.atan(info.sensor_size_v / (2.0 * info.focal_length)))
    assert vfov == pytest.approx(camera.spec.vfov_deg, abs=0.01)
    assert info.flags == (
        mavlink2.CAMERA_CAP_FLAGS_CAPTURE_IMAGE | mavlink2.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM
    )
    assert info.cam_definition_uri == ""
    assert info.time_boot_ms == 1500
    assert bytes(info.vendor_name).rstrip(b"\0") == b"swarmsitl"


def test_video_stream_information_carries_the_uri(camera):
    (vsi,) = _ack_and(camera.handle(_cmd(512, 269, 0), 0.0), 512)
    assert vsi.get_type() == "VIDEO_STREAM_INFORMATION"
    assert vsi.uri == URI
    assert (vsi.resolution_h, vsi.resolution_v, vsi.framerate, vsi.hfov) == (320, 240, 10.0, 80)
    assert vsi.type == mavlink2.VIDEO_STREAM_TYPE_TCP_MPEG
    assert vsi.flags & mavlink2.VIDEO_STREAM_STATUS_FLAGS_RUNNING
    assert _ack_and(camera.handle(_cmd(512, 269, 5), 0.0), 512, DENIED) == []  # no stream 5


def test_storage_information_is_the_run_directorys_file_system(camera, tmp_path):
    (storage,) = _ack_and(camera.handle(_cmd(512, 261, 0), 0.0), 512)
    usage = shutil.disk_usage(tmp_path)
    assert storage.status == mavlink2.STORAGE_STATUS_READY
    assert storage.total_capacity == pytest.approx(usage.total / 2**20, rel=1e-3)
    assert storage.available_capacity == pytest.approx(usage.free / 2**20, rel=0.05)


@pytest.mark.parametrize(
    ("command", "params", "reply"),
    [
        (512, (260,), "CAMERA_SETTINGS"),
        (512, (262,), "CAMERA_CAPTURE_STATUS"),
        (512, (270,), "VIDEO_STREAM_STATUS"),
        (521, (1,), "CAMERA_INFORMATION"),
        (522, (1,), "CAMERA_SETTINGS"),
        (525, (0, 1), "STORAGE_INFORMATION"),
        (527, (1,), "CAMERA_CAPTURE_STATUS"),
        (2504, (0,), "VIDEO_STREAM_INFORMATION"),
        (2505, (1,), "VIDEO_STREAM_STATUS"),
    ],
)
def test_requests_new_and_deprecated(camera, command, params, reply):
    """REQUEST_MESSAGE and the old request commands MAVSDK falls back to."""
    replies = _ack_and(camera.handle(_cmd(command, *params), 0.0), command)
    assert [m.get_type() for m in replies] == [reply]


def test_take_photo_writes_the_latest_frame_with_its_geotag(camera, tmp_path):
    """A level vehicle 30 m up, 100 m east and 200 m north of the origin, nose north, camera
    looking straight down: the geotag is there, the attitude pitch -90 deg, the file the frame."""
    north = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))  # FLU x along ENU y
    camera.on_frame(_frame(t_s=4.9, pos=(100.0, 200.0, 30.0), q_xyzw=north))
    (shot,) = _ack_and(camera.handle(_cmd(2000, 0, 0, 1, 1), 5.0), 2000)
    assert shot.get_type() == "CAMERA_IMAGE_CAPTURED"
    assert (shot.image_index, shot.capture_result) == (0, 1)
    assert (shot.lat / 1e7 - ORIGIN.lat_deg) * EARTH_M_PER_DEG == pytest.approx(200.0, abs=1.0)
    east_m_per_deg = EARTH_M_PER_DEG * math.cos(math.radians(ORIGIN.lat_deg))
    assert (shot.lon / 1e7 - ORIGIN.lon_deg) * east_m_per_deg == pytest.approx(100.0, abs=1.0)
    assert (shot.alt, shot.relative_alt) == (518_000, 30_000)
    _, pitch, _ = np.degrees(frames.euler_from_quat_ned_frd(np.array(shot.q)))
    assert pitch == pytest.approx(-90.0, abs=0.1)
    assert shot.time_boot_ms == 4900
    assert shot.time_utc == round((EPOCH_S + 4.9) * 1e6)
    path = tmp_path / "vehicle1" / "camera" / "IMG_0001.jpg"
    assert shot.file_url == path.resolve().as_uri()
    image = cv2.imread(str(path))
    assert image.shape == (240, 320, 3)
    assert image[:, :100, 2].mean() > 200  # red in BGR's last channel: colours not swapped


def test_forward_camera_attitude_follows_the_vehicle_heading(camera):
    """Nose east (NED yaw 90 deg), forward camera: the camera's yaw is 90 deg, pitch 0."""
    spec = CameraSpec(pitch_deg=0.0)
    camera.on_frame(_frame(spec=spec, q_xyzw=(0.0, 0.0, 0.0, 1.0)))  # FLU x along ENU x: east
    (shot,) = _ack_and(camera.handle(_cmd(2000, 0, 0, 1, 1), 3.0), 2000)
    roll, pitch, yaw = np.degrees(frames.euler_from_quat_ned_frd(np.array(shot.q)))
    assert (roll, pitch, yaw) == pytest.approx((0.0, 0.0, 90.0), abs=0.01)


def test_a_repeated_sequence_number_is_one_photo(camera):
    """MAVSDK retransmits IMAGE_START_CAPTURE with the same param4 when an ACK is lost."""
    camera.on_frame(_frame())
    first = camera.handle(_cmd(2000, 0, 0, 1, 7), 3.0)
    again = camera.handle(_cmd(2000, 0, 0, 1, 7), 3.1)
    nxt = camera.handle(_cmd(2000, 0, 0, 1, 8), 3.2)
    assert len(first) == 2 and _ack_and(again, 2000) == [] and len(nxt) == 2
    assert [first[1].image_index, nxt[1].image_index] == [0, 1]


def test_interval_capture_takes_count_photos_at_the_interval(camera):
    camera.on_frame(_frame())
    assert _ack_and(camera.handle(_cmd(2000, 0, 0.5, 3, 0), 10.0), 2000) == []
    shots = [
        (round(t, 3), m.image_index)
        for t in np.arange(10.0, 13.0, 0.004)
        for m in camera.tick(float(t))
        if m.get_type() == "CAMERA_IMAGE_CAPTURED"
    ]
    assert shots == [(10.0, 0), (10.5, 1), (11.0, 2)]


def test_interval_capture_until_stopped(camera):
    camera.on_frame(_frame())
    camera.handle(_cmd(2000, 0, 1.0, 0, 0), 0.0)
    times = []
    for t in np.arange(0.0, 6.0, 0.004):
        if abs(t - 3.5) < 1e-6:
            (status,) = _ack_and(camera.handle(_cmd(512, 262), t), 512)
            assert (status.image_status, status.image_interval, status.image_count) == (3, 1.0, 4)
            _ack_and(camera.handle(_cmd(2001, 0), t), 2001)
        times += [
            round(t, 3) for m in camera.tick(float(t)) if m.get_type() == "CAMERA_IMAGE_CAPTURED"
        ]
    assert times == [0.0, 1.0, 2.0, 3.0]


def test_photo_before_the_first_frame_reports_a_failure_and_counts(camera):
    (shot,) = _ack_and(camera.handle(_cmd(2000, 0, 0, 1, 1), 0.1), 2000)
    assert (shot.image_index, shot.capture_result, shot.file_url) == (0, 0, "")
    camera.on_frame(_frame())
    (shot,) = _ack_and(camera.handle(_cmd(2000, 0, 0, 1, 2), 0.2), 2000)
    assert (shot.image_index, shot.capture_result) == (1, 1)
    # MAVSDK asks again for a capture it missed: REQUEST_MESSAGE 263 with the index.
    (again,) = _ack_and(camera.handle(_cmd(512, 263, 0), 0.3), 512)
    assert (again.image_index, again.capture_result) == (0, 0)
    assert _ack_and(camera.handle(_cmd(512, 263, 9), 0.3), 512, DENIED) == []


def test_set_camera_mode_is_reported_in_the_settings(camera):
    (settings,) = _ack_and(camera.handle(_cmd(530, 0, 1), 0.0), 530)
    assert settings.mode_id == mavlink2.CAMERA_MODE_VIDEO
    assert _ack_and(camera.handle(_cmd(530, 0, 7), 0.0), 530, DENIED) == []


@pytest.mark.parametrize(
    ("command", "params", "result"),
    [
        (31000, (), UNSUPPORTED),
        (2500, (0, 1), UNSUPPORTED),  # video recording is not implemented
        (512, (), DENIED),  # NaN message id
        (512, (33,), DENIED),  # GLOBAL_POSITION_INT: not a camera message
        (2000, (0, 0, -1, 0), DENIED),
        (2000, (0, math.nan, 5, 0), DENIED),  # a series needs an interval
        (2000, (0, 0, math.inf, 0), DENIED),
    ],
)
def test_bad_or_unknown_commands_are_answered_not_raised(camera, command, params, result):
    assert _ack_and(camera.handle(_cmd(command, *params), 0.0), command, result) == []


def test_commands_for_others_and_other_messages_are_ignored(camera):
    assert camera.handle(_cmd(2000, 0, 0, 1, 1, target=(1, 1)), 0.0) == []
    assert camera.handle(_cmd(2000, 0, 0, 1, 1, target=(2, 100)), 0.0) == []
    hb = _received(mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    assert camera.handle(hb, 0.0) == []
    assert camera.stats.ignored == 2


def test_a_stream_less_camera_does_not_announce_one(tmp_path):
    camera = CameraProtocol(CameraSpec(), 3, ORIGIN, EPOCH_S, JpegStore(tmp_path))
    (info,) = _ack_and(camera.handle(_cmd(512, 259, target=(3, 100)), 0.0), 512)
    assert not info.flags & mavlink2.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM
    assert _ack_and(camera.handle(_cmd(512, 269, target=(3, 100)), 0.0), 512, DENIED) == []


def test_udp_adapter_survives_garbage_and_answers_over_udp(camera):
    """Garbage, a truncated frame and a valid request in one burst: the request is answered."""
    vehicle = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    vehicle.bind(("127.0.0.1", 0))
    vehicle.settimeout(2.0)
    manager = CameraManager(camera, "127.0.0.1", 0, vehicle.getsockname()[1])
    try:
        target = manager.local_address
        mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
        request = mavlink2.MAVLink_command_long_message(1, 100, 512, 0, 259, 0, 0, 0, 0, 0, 0)
        frame = request.pack(mav)
        vehicle.sendto(b"\xfd\x09garbage", target)
        vehicle.sendto(frame[:-4], target)
        vehicle.sendto(frame, target)
        time.sleep(0.05)
        manager.poll(0.0)
        parser = mavlink2.MAVLink(None)
        got = []
        while len(got) < 3:
            got += parser.parse_buffer(vehicle.recv(65535)) or []
        types = sorted(m.get_type() for m in got)
        assert types == ["CAMERA_INFORMATION", "COMMAND_ACK", "HEARTBEAT"]
        assert {(m.get_srcSystem(), m.get_srcComponent()) for m in got} == {(1, 100)}
        assert camera.stats.parse_errors >= 1
    finally:
        manager.close()
        manager.close()
        vehicle.close()
