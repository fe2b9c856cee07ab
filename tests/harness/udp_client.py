"""A pymavlink client on its own UDP socket, for tests that talk to a running simulation.

Bound on 127.0.0.1 (``port`` 0: an OS-picked one), read without blocking between simulation
steps. It sends to ``to``, or, while that is None, back to whoever sent it the last datagram
(a ground station that answers the vehicle's stream). With a ``key`` it signs what it sends,
as mavutil's ``setup_signing(key, sign_outgoing=True)`` does, and checks what it receives.
"""

from __future__ import annotations

import socket
import time

from pymavlink.dialects.v20 import common as mavlink2

EPOCH_2015_UNIX_S = 1_420_070_400
"""MAVLink 2 signing timestamps count 10 µs units from 2015-01-01."""


class UdpClient:
    """One MAVLink client (``sysid``, ``compid``) on a UDP socket."""

    def __init__(
        self,
        sysid: int = 255,
        compid: int = 190,
        port: int = 0,
        to: tuple[str, int] | None = None,
        key: bytes | None = None,
        link_id: int = 1,
    ) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        if key is not None:
            self.mav.signing.secret_key = key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = link_id
            self.mav.signing.timestamp = int((time.time() - EPOCH_2015_UNIX_S) * 100_000)
        self.to = to
        """Where :meth:`send` goes (None: back to :attr:`peer`)."""
        self.peer: tuple[str, int] | None = None
        """The address the last datagram came from."""
        self.inbox: list[mavlink2.MAVLink_message] = []
        """Every valid message received so far (clear it to start a window)."""

    @property
    def port(self) -> int:
        return self.sock.getsockname()[1]

    def send(self, msg: mavlink2.MAVLink_message) -> None:
        to = self.to if self.to is not None else self.peer
        assert to is not None, "nowhere to send: set .to, or wait for the vehicle's stream"
        self.sock.sendto(msg.pack(self.mav), to)
        self.mav.seq = (self.mav.seq + 1) & 0xFF

    def drain(self) -> None:
        """Read every datagram waiting; keep its valid messages in :attr:`inbox`."""
        while True:
            try:
                data, self.peer = self.sock.recvfrom(65535)
            except BlockingIOError:
                return
            self.inbox += [
                m for m in self.mav.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"
            ]

    def of(
        self, type_name: str, src: tuple[int, int] | None = None
    ) -> list[mavlink2.MAVLink_message]:
        """Messages of one type received so far, from ``src`` (sysid, compid) or anyone."""
        return [
            m
            for m in self.inbox
            if m.get_type() == type_name
            and (src is None or (m.get_srcSystem(), m.get_srcComponent()) == src)
        ]

    def close(self) -> None:
        self.sock.close()
