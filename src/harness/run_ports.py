"""The port bases of a scenario run, and free ones (light: the pytest plugin imports it)."""

from __future__ import annotations

import random
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


PORTS_LOW = 20000
"""Lowest port ``free_ports`` hands out (the fixed defaults, 14030-15450, lie below)."""
PORTS_HIGH = 32768
"""``free_ports`` hands out ports below this: Linux's first ephemeral port by default."""


def free_ports(vehicles: int = 16, rng: random.Random | None = None) -> RunPorts:
    """Port bases with ``vehicles`` free ports each, chosen at random in 20000-32767.

    Random blocks make two processes (pytest-xdist workers, two CI jobs, two sweep trials) unlikely
    to pick the same ports; each block is checked free before it is returned. Up to 20 vehicles
    a block spans 200 ports; a bigger fleet gets proportionally wider blocks. The range ends below
    Linux's ephemeral ports (32768-60999 by default): a port checked free there can be taken by
    any process's outgoing connection before the run binds it (seen: a mavsdk_server whose gRPC
    port went to another test's Dask connection, and its companion waited 60 s for nothing).
    """
    rng = rng or random.Random()
    stride = max(20, vehicles)
    block = 10 * stride
    if PORTS_LOW + block > PORTS_HIGH:
        raise ValueError(f"no room for {vehicles} vehicles' ports in {PORTS_LOW}-{PORTS_HIGH - 1}")
    for _ in range(200):
        base = rng.randrange(PORTS_LOW, PORTS_HIGH - block + 1, block)
        ports = RunPorts(
            sdk=base,
            listen=base + 2 * stride,
            grpc=base + 4 * stride,
            payload=base + 6 * stride,
            mocap=base + 7 * stride,
            net=base + 8 * stride,
            net_proxy=base + 9 * stride,
        )
        udp = [
            *range(ports.sdk, ports.sdk + vehicles),
            *range(ports.listen, ports.listen + vehicles),
            *range(ports.payload, ports.payload + vehicles),
            *range(ports.mocap, ports.mocap + vehicles),
        ]
        if all(port_free(p) for p in udp) and all(
            port_free(p, socket.SOCK_STREAM) for p in range(ports.grpc, ports.grpc + vehicles)
        ):
            return ports
    raise RuntimeError(f"no free block of ports in {PORTS_LOW}-{PORTS_HIGH - 1}")
