"""Motion capture -> autopilot: forward a vehicle's poses as VISION_POSITION_ESTIMATE.

The Raspberry-Pi role of an indoor flight: a motion-capture system streams the pose of the
vehicle's rigid body to the companion computer (here the datagrams of ``companion.mocap_wire``,
as ``swarmsitl up --mocap HZ`` publishes them), and the companion forwards each pose to the
autopilot's onboard MAVLink port, where EKF2 fuses it as external vision (EKF2_EV_CTRL). Plain
pymavlink; it knows nothing of the simulator.

VISION_POSITION_ESTIMATE carries the pose in local NED (x, y, z, roll, pitch, yaw), its sample
time in ``usec`` and the diagonal of its covariance (position sigma^2 at entries 0, 6, 11, attitude
sigma^2 at 15, 18, 20, zeros elsewhere). It is sent from component 197
(MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY) of the vehicle's own system id, with a HEARTBEAT once a
second.

Example, vehicle index 0 (system 1) of ``swarmsitl up --mocap 50``, whose poses arrive on UDP
15400 and whose onboard MAVLink port is 14580 (the defaults):

    python -m companion.scripts.mocap_bridge --vehicle 0

and vehicle index 1: ``--vehicle 1 --listen 0.0.0.0:15401 --mavlink udpout:127.0.0.1:14581``.
"""

from __future__ import annotations

import argparse
import math
import socket
import sys
import time
from dataclasses import dataclass

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from companion import mocap_wire

COMPONENT_VIO = mavlink2.MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY
"""MAVLink component id of the bridge (197)."""
HEARTBEAT_PERIOD_S = 1.0
"""Wall seconds between the bridge's HEARTBEATs."""


@dataclass
class BridgeStats:
    """What the bridge did."""

    received: int = 0
    """Datagrams received."""
    forwarded: int = 0
    """VISION_POSITION_ESTIMATE messages sent."""
    malformed: int = 0
    """Datagrams that were not poses of this format."""
    other_vehicle: int = 0
    """Poses of another vehicle (ignored)."""


def euler_from_quaternion(q: tuple[float, float, float, float]) -> tuple[float, float, float]:
    """Roll, pitch, yaw (ZYX, rad) of a unit quaternion (w, x, y, z) body FRD -> NED."""
    w, x, y, z = q
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def vision_message(pose: mocap_wire.MocapPose) -> mavlink2.MAVLink_vision_position_estimate_message:
    """The VISION_POSITION_ESTIMATE of one pose."""
    roll, pitch, yaw = euler_from_quaternion(pose.quaternion_wxyz)
    covariance = [0.0] * 21
    pos_var, att_var = pose.position_sigma_m**2, pose.attitude_sigma_rad**2
    for index, value in zip((0, 6, 11, 15, 18, 20), (pos_var,) * 3 + (att_var,) * 3, strict=True):
        covariance[index] = value
    x, y, z = pose.position_ned_m
    return mavlink2.MAVLink_vision_position_estimate_message(
        pose.time_usec, x, y, z, roll, pitch, yaw, covariance, 0
    )


def parse_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` (or ``PORT``) -> (host, port)."""
    host, _, port = text.rpartition(":")
    return host or "0.0.0.0", int(port)


def run(args: argparse.Namespace) -> BridgeStats:
    """Forward poses until ``--count`` were forwarded or ``--duration`` wall seconds passed."""
    stats = BridgeStats()
    listen = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    listen.bind(parse_address(args.listen))
    listen.settimeout(0.1)
    sysid = args.sysid if args.sysid is not None else args.vehicle + 1
    link = mavutil.mavlink_connection(
        args.mavlink, source_system=sysid, source_component=COMPONENT_VIO, dialect="common"
    )
    deadline = time.monotonic() + args.duration if args.duration > 0 else math.inf
    next_heartbeat = 0.0
    try:
        while time.monotonic() < deadline and (args.count <= 0 or stats.forwarded < args.count):
            now = time.monotonic()
            if now >= next_heartbeat:
                next_heartbeat = now + HEARTBEAT_PERIOD_S
                link.mav.heartbeat_send(
                    mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, 0
                )
            while link.recv_match(blocking=False) is not None:
                pass  # telemetry the autopilot streams back to us: not needed here
            try:
                data = listen.recv(2048)
            except TimeoutError:
                continue
            stats.received += 1
            try:
                pose = mocap_wire.decode(data)
            except mocap_wire.MocapWireError:
                stats.malformed += 1
                continue
            if pose.vehicle != args.vehicle:
                stats.other_vehicle += 1
                continue
            link.mav.send(vision_message(pose))
            stats.forwarded += 1
    finally:
        listen.close()
        link.close()
    return stats


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = argparse.ArgumentParser(
        prog="python -m companion.scripts.mocap_bridge",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--listen", default="0.0.0.0:15400", help="HOST:PORT the mocap datagrams arrive on"
    )
    parser.add_argument(
        "--mavlink",
        default="udpout:127.0.0.1:14580",
        help="pymavlink connection to the autopilot's onboard port (or a serial device)",
    )
    parser.add_argument("--vehicle", type=int, default=0, help="index of the vehicle to forward")
    parser.add_argument(
        "--sysid", type=int, default=None, help="MAVLink system id to send as [vehicle + 1]"
    )
    parser.add_argument("--count", type=int, default=0, help="stop after N poses (0 = never)")
    parser.add_argument(
        "--duration", type=float, default=0.0, help="stop after S wall seconds (0 = never)"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point."""
    args = build_parser().parse_args(argv)
    try:
        stats = run(args)
    except KeyboardInterrupt:
        return 0
    print(
        f"[mocap_bridge] received {stats.received}, forwarded {stats.forwarded}, "
        f"malformed {stats.malformed}, other vehicles {stats.other_vehicle}",
        flush=True,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
