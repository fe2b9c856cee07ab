"""Free TCP ports for the camera-stream tests (imported by basename from tests/harness)."""

from __future__ import annotations

import socket

RANGE = (46300, 46500)
"""Where the camera-stream tests look for ports (this suite's block)."""


def free_tcp_base(count: int) -> int:
    """The first port of ``count`` consecutive TCP ports of RANGE nobody holds now on 127.0.0.1.

    Looked up at run time, so two test runs at once (or another program) do not collide on a
    fixed port.
    """
    for base in range(RANGE[0], RANGE[1] - count + 1):
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
    raise RuntimeError(f"no {count} consecutive free TCP ports in {RANGE}")
