"""How datagrams leave and reach a node: real UDP, or a port handed in by the harness.

A ``Node`` talks to a ``Transport`` only; which one is a matter of configuration:

- ``UdpTransport``: a real UDP socket bound to the node's address, sending to each
  destination's route (the harness's link router) or address (real hardware).
- ``PortTransport``: in-process (lockstep) use; wraps any ``DatagramPort`` (the harness's
  link model in simulation time).
"""

from __future__ import annotations

import socket
from typing import Protocol, runtime_checkable

from companion.net.config import NetConfig

MAX_RECEIVE_PER_CALL = 4096
"""Datagrams ``UdpTransport.receive`` reads at most per call (the rest wait for the next)."""
SOCKET_BUFFER_BYTES = 4 * 1024 * 1024
"""Requested kernel receive/send buffer of the UDP socket, bytes (the OS may cap it)."""


@runtime_checkable
class Transport(Protocol):
    """Moves whole datagrams between this node and the others."""

    def send(self, dst: str, data: bytes) -> None:
        """Send one datagram to node ``dst``; failures are counted, not raised."""

    def receive(self) -> list[bytes]:
        """Datagrams received since the last call (never blocks)."""

    def fileno(self) -> int | None:
        """File descriptor that becomes readable when datagrams arrive, or None."""

    def close(self) -> None:
        """Release the transport's resources."""


@runtime_checkable
class DatagramPort(Protocol):
    """What the harness hands to ``PortTransport``: a datagram switch keyed by node id."""

    def send(self, src: str, dst: str, data: bytes) -> None:
        """Accept one datagram from ``src`` for ``dst`` (the port delays/drops it)."""

    def receive(self, node_id: str) -> list[bytes]:
        """Datagrams delivered to ``node_id`` since the last call."""


class UdpTransport:
    """A UDP socket bound to the node's configured address."""

    def __init__(self, config: NetConfig, node_id: str) -> None:
        if node_id not in config.nodes:
            raise ValueError(f"node_id: {node_id!r} is not a node of the configuration")
        self._config = config
        self.node_id = node_id
        self.send_errors = 0
        """Datagrams the OS refused to send (counted, never raised)."""
        self.receive_errors = 0
        """Errors while receiving, e.g. ICMP port unreachable reported by Linux."""
        self._resolved: dict[str, tuple[str, int]] = {}
        host, port = config.nodes[node_id].address
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            for option in (socket.SO_RCVBUF, socket.SO_SNDBUF):
                self._sock.setsockopt(socket.SOL_SOCKET, option, SOCKET_BUFFER_BYTES)
            self._sock.bind((host, port))
        except OSError as exc:
            self._sock.close()
            raise OSError(
                exc.errno,
                f"node {node_id} cannot bind nodes.{node_id}.address {host}:{port}: "
                f"{exc.strerror or exc}",
            ) from exc
        self._sock.setblocking(False)

    def send(self, dst: str, data: bytes) -> None:
        """Send one datagram to ``dst`` (its route, else its address)."""
        if dst not in self._config.nodes:
            raise ValueError(f"dst: unknown node {dst!r}")
        try:
            address = self._resolved.get(dst)
            if address is None:  # host names are resolved once, at the first send
                host, port = self._config.send_address(dst)
                address = self._resolved[dst] = (socket.gethostbyname(host), port)
            self._sock.sendto(data, address)
        except OSError:
            self.send_errors += 1

    def receive(self) -> list[bytes]:
        """Read every waiting datagram (up to ``MAX_RECEIVE_PER_CALL``)."""
        out: list[bytes] = []
        while len(out) < MAX_RECEIVE_PER_CALL:
            try:
                data = self._sock.recv(65535)
            except BlockingIOError:
                break
            except ConnectionRefusedError:  # Linux reports an earlier ICMP port unreachable
                self.receive_errors += 1
                continue
            except OSError:
                self.receive_errors += 1
                break
            out.append(data)
        return out

    def fileno(self) -> int | None:
        """The socket's file descriptor (None once closed)."""
        fd = self._sock.fileno()
        return fd if fd >= 0 else None

    def close(self) -> None:
        """Close the socket."""
        self._sock.close()


class PortTransport:
    """In-process transport over a ``DatagramPort`` (lockstep runs in the harness)."""

    def __init__(self, port: DatagramPort, node_id: str) -> None:
        self._port = port
        self.node_id = node_id
        self.send_errors = 0
        """Always 0: the port itself drops and counts."""

    def send(self, dst: str, data: bytes) -> None:
        """Hand one datagram to the port."""
        self._port.send(self.node_id, dst, data)

    def receive(self) -> list[bytes]:
        """Datagrams the port delivered to this node."""
        return self._port.receive(self.node_id)

    def fileno(self) -> int | None:
        """None: the owner polls (there is no descriptor)."""
        return None

    def close(self) -> None:
        """Nothing to release."""
