"""A Pixhawk in hardware-in-the-loop: PX4's simulator messages over its USB serial port.

In HITL (PX4 ``SYS_HITL`` = 1) the flight controller runs its real firmware and clock; the
simulator replaces its sensors. PX4 reads HIL_SENSOR and HIL_GPS on its USB MAVLink instance
(``/dev/ttyACM0`` on the host; the baud rate is nominal on USB, 921600 by convention) and sends
HIL_ACTUATOR_CONTROLS there (about 200 Hz, ``flags`` 0: not lockstep). The USB port is then the
vehicle's only MAVLink link, so the simulator relays everything else both ways between it and
UDP, as Gazebo-classic's HITL plugin does: every frame from the board goes to the ground station
(14550) and the offboard API (14540+i); every datagram from them goes to the board.

:class:`SerialPort` is the device, opened raw and non-blocking (it has the ``recv``/``send``/
``fileno``/``close`` of a socket, so :class:`~sitl.hil_server.HilServer` treats it as a
connection); :class:`UdpRelay` is the UDP side.
"""

from __future__ import annotations

import contextlib
import errno
import os
import socket
import termios
import tty

BAUD_RATES = {
    57600: termios.B57600,
    115200: termios.B115200,
    230400: termios.B230400,
    460800: termios.B460800,
    921600: termios.B921600,
    1500000: termios.B1500000,
    2000000: termios.B2000000,
}
"""Baud rates a HIL serial port may be opened at (USB ignores it; a UART needs the board's)."""


def parse_serial(spec: str) -> tuple[str, int]:
    """``/dev/ttyACM0`` or ``/dev/ttyACM0:921600`` -> (device, baud). ValueError if malformed."""
    device, sep, baud_text = spec.rpartition(":")
    if not sep or not baud_text.isdigit():
        device, baud = spec, 921600
    else:
        baud = int(baud_text)
    if not device:
        raise ValueError(f"{spec!r}: expected DEVICE[:BAUD], e.g. /dev/ttyACM0:921600")
    if baud not in BAUD_RATES:
        raise ValueError(f"{spec!r}: baud {baud} is not one of {sorted(BAUD_RATES)}")
    return device, baud


class SerialPort:
    """A serial device as a non-blocking byte stream with a socket's interface."""

    def __init__(self, device: str, baud: int = 921600) -> None:
        if baud not in BAUD_RATES:
            raise ValueError(f"baud {baud} is not one of {sorted(BAUD_RATES)}")
        try:
            self._fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as exc:
            raise OSError(
                exc.errno, f"cannot open the HIL serial port {device}: {exc.strerror}"
            ) from exc
        try:
            tty.setraw(self._fd)
            attrs = termios.tcgetattr(self._fd)
            attrs[4] = attrs[5] = BAUD_RATES[baud]  # ispeed, ospeed
            termios.tcsetattr(self._fd, termios.TCSANOW, attrs)
        except termios.error as exc:
            os.close(self._fd)
            raise OSError(errno.ENOTTY, f"{device} is not a serial port ({exc})") from exc
        self.device = device
        self.baud = baud

    def fileno(self) -> int:
        """The device's descriptor."""
        return self._fd

    def recv(self, size: int) -> bytes:
        """Bytes available now (BlockingIOError: none; b'': the device went away)."""
        try:
            return os.read(self._fd, size)
        except OSError as exc:
            if exc.errno == errno.EIO:  # the other end (USB device, pty) is gone
                return b""
            raise

    def send(self, data: bytes | bytearray) -> int:
        """Write what fits now; the number of bytes written (BlockingIOError: none)."""
        return os.write(self._fd, data)

    def close(self) -> None:
        """Close the device."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class UdpRelay:
    """The UDP side of a HITL board: frames to the ground station and the API, and back."""

    def __init__(self, bind_addr: str, peers: tuple[tuple[str, int], ...]) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((bind_addr, 0))
        self.sock.setblocking(False)
        self.peers = list(peers)
        self.frames_out = 0
        self.datagrams_in = 0

    def fileno(self) -> int:
        """The UDP socket's descriptor."""
        return self.sock.fileno()

    def forward(self, frame: bytes) -> None:
        """Send one frame from the board to every peer (and every address heard from)."""
        self.frames_out += 1
        for peer in self.peers:
            # Nobody listening (ICMP unreachable), a full buffer: UDP drops the frame.
            with contextlib.suppress(OSError):
                self.sock.sendto(frame, peer)

    def receive(self) -> list[bytes]:
        """Datagrams the ground station or the API sent; their senders become peers."""
        out = []
        while True:
            try:
                data, address = self.sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return out
            except OSError:
                continue  # an ICMP error of an earlier send
            self.datagrams_in += 1
            if address not in self.peers:
                self.peers.append(address)
            out.append(data)

    def close(self) -> None:
        """Close the UDP socket."""
        self.sock.close()
