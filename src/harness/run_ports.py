"""The port bases of a scenario run (light: the pytest plugin imports it at start-up)."""

from __future__ import annotations

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
