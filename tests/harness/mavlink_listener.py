"""A plain UDP socket where a MAVLink client would listen: decodes and counts what arrives."""

from __future__ import annotations

import socket

from pymavlink.dialects.v20 import common as mavlink2


class MavlinkListener:
    """Bound to an OS-picked port on 127.0.0.1 (``.port``), as MAVSDK's ``udpin`` socket."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.port = self.sock.getsockname()[1]
        self.mav = mavlink2.MAVLink(None, 245, 190)
        self.mav.robust_parsing = True
        self.inbox: list = []
        """Every valid message received so far (clear it to start a window)."""
        self.bytes = 0
        """Bytes of every datagram received."""

    def drain(self) -> list:
        """Read what arrived; return its valid messages (also appended to ``inbox``)."""
        out = []
        while True:
            try:
                data = self.sock.recv(65535)
            except BlockingIOError:
                self.inbox.extend(out)
                return out
            self.bytes += len(data)
            out += [m for m in self.mav.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]

    def close(self) -> None:
        self.sock.close()
