"""The port bases of a scenario run (light: the pytest plugin imports it at start-up)."""

from __future__ import annotations

import socket
from dataclasses import dataclass


@dataclass(frozen=True)
class RunPorts:
    """Port bases of a run; vehicle i uses base + i (pick other bases to run two at once)."""

    sdk: int = 14540
    """Where vehicle i's onboard link sends (MAVSDK: udpin://0.0.0.0:sdk+i)."""
    listen: int = 14580
    """Where vehicle i's onboard link listens."""
    grpc: int = 50051
    """Port of vehicle i's companion's mavsdk_server (SWARMSITL_GRPC_PORT)."""
    payload: int = 14030
    """Vehicle i's MAVLink camera (component 100); 0: no MAVLink camera."""
    mocap: int = 15400
    """Where vehicle i's motion-capture datagrams go (+i; GPS-denied worlds)."""
    net: int = 47000
    """First node-messaging port (with ``node`` roles)."""
    net_proxy: int = 47500
    """First port of the node-messaging router."""


def port_free(port: int, kind: int = socket.SOCK_DGRAM) -> bool:
    """Nobody holds ``port`` (UDP on 0.0.0.0, which MAVSDK binds; TCP on localhost, gRPC's)."""
    host = "0.0.0.0" if kind == socket.SOCK_DGRAM else "127.0.0.1"
    with socket.socket(socket.AF_INET, kind) as sock:
        try:
            sock.bind((host, port))
        except OSError:
            return False
    return True


def free_tcp_ports(base: int, count: int) -> list[int]:
    """``count`` TCP ports from ``base`` up, skipping any that is taken (a leftover server).

    A companion's mavsdk_server that cannot bind its gRPC port exits, and its program waits for
    it; a taken port is skipped instead (the companion is told the one it got).
    """
    out: list[int] = []
    port = base
    while len(out) < count:
        if port > 65535:
            raise ValueError(f"no {count} free TCP ports from {base} up")
        if port_free(port, socket.SOCK_STREAM):
            out.append(port)
        port += 1
    return out
