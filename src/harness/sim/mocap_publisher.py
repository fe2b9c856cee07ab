"""Publishes the world's motion-capture samples as UDP datagrams, one per vehicle per sample.

The format is ``companion.mocap_wire`` (what a companion computer's mocap client decodes);
vehicle i's datagrams go to ``host:base_port + i``, as a motion-capture server streams each
rigid body to the computer that flies it.
"""

from __future__ import annotations

import logging
import socket

from companion import mocap_wire
from sitl.sensors.mocap import MocapSample

log = logging.getLogger(__name__)


class MocapPublisher:
    """One UDP socket sending every vehicle's poses."""

    def __init__(self, host: str, base_port: int, n_vehicles: int) -> None:
        if not 0 < base_port <= 65535 - (n_vehicles - 1):
            raise ValueError(f"mocap base port {base_port} + {n_vehicles} vehicles out of range")
        self._targets = [(host, base_port + i) for i in range(n_vehicles)]
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setblocking(False)
        self._sequence = [0] * n_vehicles
        self.datagrams_sent = 0
        self.send_errors = 0

    def publish(self, samples: list[MocapSample]) -> None:
        """Send each sample's pose of every vehicle (nothing for an empty list)."""
        for sample in samples:
            time_usec = round(sample.time_s * 1e6)
            positions = sample.position_ned_m.tolist()
            quaternions = sample.quaternion_wxyz.tolist()
            for i, target in enumerate(self._targets):
                pose = mocap_wire.MocapPose(
                    vehicle=i,
                    sequence=self._sequence[i],
                    time_usec=time_usec,
                    position_ned_m=tuple(positions[i]),
                    quaternion_wxyz=tuple(quaternions[i]),
                    position_sigma_m=sample.position_sigma_m,
                    attitude_sigma_rad=sample.attitude_sigma_rad,
                )
                self._sequence[i] += 1
                try:
                    self._sock.sendto(mocap_wire.encode(pose), target)
                    self.datagrams_sent += 1
                except OSError as exc:  # nobody listening (ICMP refused), buffer full
                    self.send_errors += 1
                    if self.send_errors == 1:
                        log.info("mocap datagram to %s:%d not sent: %s", *target, exc)

    def close(self) -> None:
        """Release the socket (idempotent)."""
        self._sock.close()
