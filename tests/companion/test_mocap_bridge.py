"""Motion-capture datagrams: the wire format, and the bridge to VISION_POSITION_ESTIMATE over
real loopback UDP sockets."""

from __future__ import annotations

import math
import socket
import threading

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2

from companion import mocap_wire
from companion.scripts import mocap_bridge
from harness.run.ports import free_port_block
from harness.sim.mocap_publisher import MocapPublisher
from sitl.sensors.mocap import MocapSample

pytestmark = pytest.mark.sockets

YAW = 0.7
Q_YAW = (math.cos(YAW / 2), 0.0, 0.0, math.sin(YAW / 2))


def _free_udp_port() -> int:
    """A port nobody holds, from the suite's allocator (this xdist worker's own slice)."""
    return free_port_block()


def test_datagram_round_trip():
    """56 bytes; every field survives (positions and quaternion to float32 precision)."""
    pose = mocap_wire.MocapPose(3, 2**32 + 5, 123_456_789, (1.5, -2.25, -0.75), Q_YAW, 0.001, 0.005)
    data = mocap_wire.encode(pose)
    assert len(data) == mocap_wire.SIZE_BYTES == 56
    back = mocap_wire.decode(data)
    assert (back.vehicle, back.sequence, back.time_usec) == (3, 5, 123_456_789)
    assert back.position_ned_m == pytest.approx(pose.position_ned_m)
    assert back.quaternion_wxyz == pytest.approx(Q_YAW, abs=1e-7)
    assert (back.position_sigma_m, back.attitude_sigma_rad) == pytest.approx((0.001, 0.005))


@pytest.mark.parametrize(
    ("data", "reason"),
    [
        (b"SWMC" + bytes(10), "expected 56 bytes"),
        (b"XXXX" + bytes(52), "not a version-1"),
        (b"SWMC\x01\x07" + bytes(50), "unknown frame"),
    ],
)
def test_malformed_datagrams_are_refused(data, reason):
    """Wrong length, magic or frame raise MocapWireError."""
    with pytest.raises(mocap_wire.MocapWireError, match=reason):
        mocap_wire.decode(data)


def test_bridge_forwards_poses_of_its_vehicle_as_vision_position_estimate():
    """Publisher -> UDP -> bridge -> UDP -> autopilot port: VISION_POSITION_ESTIMATE with the
    pose, its sample time and sigma^2 on the covariance diagonal; other vehicles' poses and
    garbage are dropped."""
    mocap_port = _free_udp_port()
    autopilot = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    autopilot.bind(("127.0.0.1", 0))
    autopilot.settimeout(0.05)
    args = mocap_bridge.build_parser().parse_args(
        [
            "--listen",
            f"127.0.0.1:{mocap_port}",
            "--mavlink",
            f"udpout:127.0.0.1:{autopilot.getsockname()[1]}",
            "--vehicle",
            "0",
            "--count",
            "3",
            "--duration",
            "20",
        ]
    )
    result: list[mocap_bridge.BridgeStats] = []
    bridge = threading.Thread(target=lambda: result.append(mocap_bridge.run(args)), daemon=True)
    bridge.start()
    publisher = MocapPublisher("127.0.0.1", mocap_port, 1)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    parser = mavlink2.MAVLink(None)
    received: list = []
    sample_times = []
    try:
        for k in range(400):  # until three arrive (the bridge may not be bound yet at first)
            t = 1.0 + 0.02 * k
            sample = MocapSample(
                time_s=t,
                position_ned_m=np.array([[1.0 + k, -2.0, -3.0]]),
                quaternion_wxyz=np.array([Q_YAW]),
                position_sigma_m=0.002,
                attitude_sigma_rad=0.01,
            )
            other = mocap_wire.MocapPose(5, k, 0, (0.0, 0.0, 0.0), Q_YAW, 0.0, 0.0)
            sender.sendto(mocap_wire.encode(other), ("127.0.0.1", mocap_port))
            sender.sendto(b"garbage", ("127.0.0.1", mocap_port))
            publisher.publish([sample])
            sample_times.append(round(t * 1e6))
            try:
                data = autopilot.recv(4096)
            except TimeoutError:
                continue
            msgs = parser.parse_buffer(data) or []
            received += [m for m in msgs if m.get_type() == "VISION_POSITION_ESTIMATE"]
            if len(received) >= 3 or not bridge.is_alive():
                break
        bridge.join(timeout=30)
        while len(received) < 3:  # what the bridge sent just before it stopped is still queued
            try:
                data = autopilot.recv(4096)
            except TimeoutError:
                break
            msgs = parser.parse_buffer(data) or []
            received += [m for m in msgs if m.get_type() == "VISION_POSITION_ESTIMATE"]
    finally:
        bridge.join(timeout=30)
        publisher.close()
        sender.close()
        autopilot.close()
    assert len(received) == 3
    for vpe in received:
        assert vpe.get_srcSystem() == 1 and vpe.get_srcComponent() == 197
        assert vpe.usec in sample_times
        k = sample_times.index(vpe.usec)
        assert (vpe.x, vpe.y, vpe.z) == pytest.approx((1.0 + k, -2.0, -3.0))
        assert (vpe.roll, vpe.pitch, vpe.yaw) == pytest.approx((0.0, 0.0, YAW), abs=1e-6)
        cov = list(vpe.covariance)
        assert [cov[i] for i in (0, 6, 11)] == pytest.approx([4e-6] * 3)
        assert [cov[i] for i in (15, 18, 20)] == pytest.approx([1e-4] * 3)
    stats = result[0]
    assert stats.forwarded == 3
    assert stats.other_vehicle >= 1 and stats.malformed >= 1


def test_help_names_the_example():
    """--help documents the options and an example command line."""
    text = mocap_bridge.build_parser().format_help()
    for needle in (
        "--listen",
        "--mavlink",
        "--vehicle",
        "python -m companion.scripts.mocap_bridge",
    ):
        assert needle in text
