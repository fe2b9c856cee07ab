"""Wire format of the emulated motion-capture system: one UDP datagram per vehicle per sample.

56 bytes, little-endian (``struct`` format ``<4sBBHIQ3f4f2f``):

=======  ====  =======  ========================================================================
offset   size  type     field
=======  ====  =======  ========================================================================
0        4     bytes    magic ``b"SWMC"``
4        1     uint8    version, 1
5        1     uint8    frame: 1 = local NED of the capture volume (x north, y east, z down)
6        2     uint16   vehicle index, 0-based (its MAVLink system id is index + 1)
8        4     uint32   sequence number of this vehicle's samples (wraps at 2^32)
12       8     uint64   time_usec: measurement time, microseconds on the simulation clock
20       12    3 float  x, y, z: position of the centre of mass, m
32       16    4 float  q w, x, y, z: attitude, body FRD to the capture frame
48       4     float    position_sigma_m: 1-sigma position noise per axis, m
52       4     float    attitude_sigma_rad: 1-sigma noise per Euler angle, rad
=======  ====  =======  ========================================================================

The simulator's publisher (``swarmsitl up --mocap HZ``) sends vehicle i's datagrams to UDP port
``base + i``; ``companion.scripts.mocap_bridge`` turns them into VISION_POSITION_ESTIMATE.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

MAGIC = b"SWMC"
VERSION = 1
FRAME_LOCAL_NED = 1
_FORMAT = struct.Struct("<4sBBHIQ3f4f2f")
SIZE_BYTES = _FORMAT.size
"""Length of one datagram, bytes (56)."""


class MocapWireError(ValueError):
    """A datagram that is not a pose of this format."""


@dataclass(frozen=True)
class MocapPose:
    """One vehicle's pose in one datagram."""

    vehicle: int
    """Vehicle index, 0-based."""
    sequence: int
    """Sample counter of this vehicle."""
    time_usec: int
    """Measurement time, us (simulation clock)."""
    position_ned_m: tuple[float, float, float]
    """Position in the capture frame (local NED), m."""
    quaternion_wxyz: tuple[float, float, float, float]
    """Attitude body FRD -> capture frame."""
    position_sigma_m: float
    """1-sigma position noise per axis, m."""
    attitude_sigma_rad: float
    """1-sigma noise per Euler angle, rad."""


def encode(pose: MocapPose) -> bytes:
    """One datagram of ``pose``."""
    return _FORMAT.pack(
        MAGIC,
        VERSION,
        FRAME_LOCAL_NED,
        pose.vehicle,
        pose.sequence & 0xFFFFFFFF,
        pose.time_usec,
        *pose.position_ned_m,
        *pose.quaternion_wxyz,
        pose.position_sigma_m,
        pose.attitude_sigma_rad,
    )


def decode(data: bytes) -> MocapPose:
    """The pose in a datagram; :class:`MocapWireError` if it is not one of ours."""
    if len(data) != SIZE_BYTES:
        raise MocapWireError(f"expected {SIZE_BYTES} bytes, got {len(data)}")
    magic, version, frame, vehicle, seq, t_us, x, y, z, qw, qx, qy, qz, sp, sa = _FORMAT.unpack(
        data
    )
    if magic != MAGIC or version != VERSION:
        raise MocapWireError(f"not a version-{VERSION} mocap datagram ({magic!r} v{version})")
    if frame != FRAME_LOCAL_NED:
        raise MocapWireError(f"unknown frame {frame}")
    return MocapPose(vehicle, seq, t_us, (x, y, z), (qw, qx, qy, qz), sp, sa)
