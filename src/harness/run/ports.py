"""The port bases of a scenario run, and free ones (light: the pytest plugin imports it)."""

from __future__ import annotations

import os
import random
import socket
from collections.abc import Callable
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


def worker_slice() -> tuple[int, int]:
    """The ports this process may hand out, ``[low, high)``: its pytest-xdist worker's share.

    Under pytest-xdist (``PYTEST_XDIST_WORKER`` = ``gw<i>``, ``PYTEST_XDIST_WORKER_COUNT`` = n)
    worker i owns slice i of n equal slices of PORTS_LOW..PORTS_HIGH-1, so two workers can never
    pick the same port (a check that a port is free says nothing about a port another worker has
    picked but not bound yet). The subprocesses a test starts inherit the variables, and with
    them the slice. Without xdist: the whole range.
    """
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    count = os.environ.get("PYTEST_XDIST_WORKER_COUNT", "")
    if not (worker.startswith("gw") and worker[2:].isdigit() and count.isdigit()):
        return PORTS_LOW, PORTS_HIGH
    workers = max(int(count), 1)
    index = int(worker[2:]) % workers
    width = (PORTS_HIGH - PORTS_LOW) // workers
    return PORTS_LOW + index * width, PORTS_LOW + (index + 1) * width


_HANDED_OUT: list[range] = []
"""Port ranges this process handed out, oldest first: never handed out twice while remembered.

A free check cannot see a port handed out and not bound yet (a module's ports chosen when
pytest imports it, bound when its first test runs); this list can. Its oldest half is
forgotten only when the slice has no other free room.
"""


def _claimed(span: range) -> bool:
    return any(span.start < r.stop and r.start < span.stop for r in _HANDED_OUT)


def _pick(
    width: int,
    step: int,
    is_free: Callable[[int], bool],
    rng: random.Random,
    what: str,
) -> int:
    """A base in this worker's slice whose ``width`` ports are unclaimed and ``is_free``.

    Random bases (multiples of ``step`` from the slice's start) make two processes sharing a
    slice (two sweep trials, a test and its subprocess) unlikely to pick the same ports.
    """
    low, high = worker_slice()
    if width > high - low:
        raise ValueError(f"no room for {what} in {low}-{high - 1}")
    while True:
        for _ in range(200):
            base = rng.randrange(low, high - width + 1, step)
            span = range(base, base + width)
            if not _claimed(span) and is_free(base):
                _HANDED_OUT.append(span)
                return base
        mine = [r for r in _HANDED_OUT if r.start < high and low < r.stop]
        if not mine:
            break
        for span in mine[: max(len(mine) // 2, 1)]:  # the slice is full: forget the oldest half
            _HANDED_OUT.remove(span)
    raise RuntimeError(f"no free {what} in {low}-{high - 1}")


def free_port_block(count: int = 1, rng: random.Random | None = None) -> int:
    """The first of ``count`` consecutive ports, free for UDP and TCP, in this worker's slice.

    For tests that need a single port or a small block (a listening socket, a module's e2e
    ports, a camera stream's TCP ports): drawn like :func:`free_ports`' blocks, from the same
    slice and the same record of handed-out ports, so no two callers of one process get the same
    port and no two xdist workers ever do. Where the code under test accepts port 0, letting the
    OS choose is simpler still.
    """
    if count < 1:
        raise ValueError(f"count must be at least 1, not {count}")

    def is_free(base: int) -> bool:
        span = range(base, base + count)
        return all(port_free(p) for p in span) and all(
            port_free(p, socket.SOCK_STREAM) for p in span
        )

    return _pick(count, 1, is_free, rng or random.Random(), f"block of {count} ports")


def free_ports(vehicles: int = 16, rng: random.Random | None = None) -> RunPorts:
    """Port bases with ``vehicles`` free ports each, chosen at random in this worker's slice.

    The slice is 20000-32767 (PORTS_LOW..PORTS_HIGH-1), or under pytest-xdist worker i's
    i-th of n equal shares of it (:func:`worker_slice`): two workers never pick the same port,
    and within one process no block is handed out twice (:func:`free_port_block` draws from the
    same record). Random blocks make two processes sharing a slice (two sweep trials, two CI
    jobs) unlikely to pick the same ports; each block is checked free before it is returned.
    Up to 19 vehicles a block spans 200 ports; a bigger fleet gets proportionally wider blocks.
    The range ends below Linux's ephemeral ports (32768-60999 by default): a port checked free
    there can be taken by any process's outgoing connection before the run binds it (seen: a
    mavsdk_server whose gRPC port went to another test's Dask connection, and its companion
    waited 60 s for nothing).
    """
    stride = max(20, vehicles + 1)  # messaging: a node per vehicle and the cloud
    block = 10 * stride

    def layout(base: int) -> RunPorts:
        return RunPorts(
            sdk=base,
            listen=base + 2 * stride,
            grpc=base + 4 * stride,
            payload=base + 6 * stride,
            mocap=base + 7 * stride,
            net=base + 8 * stride,
            net_proxy=base + 9 * stride,
        )

    def is_free(base: int) -> bool:
        ports = layout(base)
        udp = [
            *range(ports.sdk, ports.sdk + vehicles),
            *range(ports.listen, ports.listen + vehicles),
            *range(ports.payload, ports.payload + vehicles),
            *range(ports.mocap, ports.mocap + vehicles),
            *range(ports.net, ports.net + vehicles + 1),  # the cloud node too
            *range(ports.net_proxy, ports.net_proxy + vehicles + 1),
        ]
        tcp = range(ports.grpc, ports.grpc + vehicles)
        return all(port_free(p) for p in udp) and all(port_free(p, socket.SOCK_STREAM) for p in tcp)

    base = _pick(block, block, is_free, rng or random.Random(), f"ports for {vehicles} vehicles")
    return layout(base)
