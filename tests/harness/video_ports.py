"""Free TCP ports for the camera-stream tests (imported by basename from tests/harness)."""

from __future__ import annotations

import os
import socket

RANGE = (46300, 46500)
"""Where the camera-stream tests look for ports (this suite's block)."""


def _worker_range() -> tuple[int, int]:
    """This pytest-xdist worker's share of RANGE (all of it without ``-n``): the modules of two
    workers probe at the same moment, and must not both find the same ports free."""
    workers = max(int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")), 1)
    index = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw") or 0) % workers
    width = (RANGE[1] - RANGE[0]) // workers
    return RANGE[0] + index * width, RANGE[0] + (index + 1) * width


def free_tcp_base(count: int) -> int:
    """The first port of ``count`` consecutive TCP ports of RANGE nobody holds now on 127.0.0.1.

    Looked up at run time, so two test runs at once (or another program) do not collide on a
    fixed port.
    """
    low, high = _worker_range()
    for base in range(low, high - count + 1):
        probes = []
        try:
            for port in range(base, base + count):
                sock = socket.socket()
                probes.append(sock)
                sock.bind(("127.0.0.1", port))
        except OSError:
            continue
        finally:
            for sock in probes:
                sock.close()
        return base
    raise RuntimeError(f"no {count} consecutive free TCP ports in {low}..{high - 1}")
