"""What a MAVLink link sends and receives bytes through: a UDP socket or a pseudo-terminal.

A PX4 MAVLink instance runs on a UDP port (PX4 SITL's links) or on a serial device (``mavlink
start -d /dev/ttyS2 -b 921600 -m onboard``: TELEM2 to a companion computer). The endpoint
(:mod:`autopilot_emu.mavlink.endpoint`) speaks to either through the small socket-like
:class:`Transport` interface: ``recvfrom``, ``sendto``, ``fileno``, ``getsockname``, ``close``.
A UDP socket is one as it is; :class:`PtyTransport` is the serial port: a pseudo-terminal whose
slave end companion code opens as it opens ``/dev/ttyAMA0`` on a Pi (MAVSDK
``serial:///path:921600``, pymavlink ``mavlink_connection(path, baud=921600)``).

A pseudo-terminal is a byte stream, not datagrams: a read may end inside a frame and may hold
garbage between frames, so the endpoint keeps its parser's partial frame across reads when
:attr:`Transport.is_stream` is set (it drops it at the end of each datagram otherwise).

Writing never blocks the simulation. The master end is non-blocking; a frame goes out whole or
not at all:

* the kernel's pty buffer is full (no reader, or one slower than the link): the frame is
  dropped, counted in :attr:`PtyTransport.dropped_frames`, and ``sendto`` raises
  ``BlockingIOError`` (the endpoint counts it as a send error). While nobody has the port
  open the buffer fills with the newest telemetry (a few tens of kB, well under a second at
  921600 baud) and then drops; a client that opens the port reads those stale bytes first,
  which its MAVLink parser takes as it would a UART's backlog;
* a short write (the buffer had room for part of a frame): the rest is kept and written before
  anything else, so the stream never carries a cut frame;
* EIO (the kernel reports it when no slave end is open; the transport keeps one open itself,
  so only a closing pty sees it): dropped and counted, like EAGAIN.
"""

from __future__ import annotations

import errno
import logging
import os
import termios
import tty
from pathlib import Path
from typing import Protocol, runtime_checkable

logger = logging.getLogger(__name__)

Address = tuple[str, int]
"""Where a frame came from / goes to: a UDP (host, port), or (device path, 0) on a pty."""

PTY_READ_BYTES = 256
"""Bytes read from the pty per ``recvfrom`` (the endpoint drains up to 64 reads per poll). Below
a link model's largest datagram (280 B, a signed MAVLink 2 frame): a modelled UART takes each
read as one transfer, and would refuse a larger one as oversize."""
SERIAL_BAUD = 921600
"""Baud rate set on the pty (PX4 TELEM2 to a companion: ``mavlink start -b 921600``); a pty
has no line rate of its own, the link model (``--link uart``) enforces the byte budget."""


@runtime_checkable
class Transport(Protocol):
    """The part of a UDP socket's interface a MAVLink endpoint uses."""

    is_stream: bool
    """True for a byte stream (a serial port): frames may span reads."""

    def recvfrom(self, bufsize: int) -> tuple[bytes, Address]:
        """Read what arrived; raises BlockingIOError when nothing did."""
        ...

    def sendto(self, data: bytes, address: Address) -> int:
        """Send one frame; raises OSError when it cannot go out now (counted, never retried)."""
        ...

    def fileno(self) -> int:
        """File descriptor for a readiness poll (readable when data arrived)."""
        ...

    def getsockname(self) -> Address:
        """Local address of the link."""
        ...

    def close(self) -> None:
        """Release the link; safe to call twice."""
        ...


class PtyTransport:
    """A pseudo-terminal standing for a flight controller's serial port (TELEM2).

    The simulator holds the master end (non-blocking) and keeps the slave end open (so the
    master never sees a hang-up while no client has the port open); the slave is raw (no
    echo, no line editing, 8 bits) at :data:`SERIAL_BAUD`. With ``link_path`` a symlink there
    points at the slave device (``/dev/pts/N``), for a path that stays the same between runs;
    it is removed on close.

    Raises:
        OSError: no pseudo-terminal could be opened, or ``link_path`` cannot be created.
    """

    is_stream = True

    def __init__(self, link_path: Path | None = None) -> None:
        master, slave = os.openpty()
        try:
            tty.setraw(slave)
            attrs = termios.tcgetattr(slave)
            speed = getattr(termios, f"B{SERIAL_BAUD}", None)
            if speed is not None:
                attrs[4] = attrs[5] = speed
            termios.tcsetattr(slave, termios.TCSANOW, attrs)
            os.set_blocking(master, False)
            self.device = os.ttyname(slave)
            """The slave end's device, e.g. /dev/pts/7."""
            self.link_path = None if link_path is None else Path(link_path)
            """The stable symlink to :attr:`device` (None: none)."""
            if self.link_path is not None:
                self.link_path.parent.mkdir(parents=True, exist_ok=True)
                if self.link_path.is_symlink() or self.link_path.exists():
                    self.link_path.unlink()
                self.link_path.symlink_to(self.device)
        except BaseException:
            os.close(master)
            os.close(slave)
            raise
        self._master: int | None = master
        self._slave: int | None = slave
        self._pending = b""
        """The unwritten rest of a frame cut by a short write; goes out before anything else."""
        self.dropped_frames = 0
        """Frames not written because the pty buffer was full (or the pty failed)."""
        self.dropped_bytes = 0
        self.bytes_written = 0
        """Bytes that went into the pty (towards the client)."""

    @property
    def path(self) -> str:
        """What a client opens: the symlink if there is one, else the device."""
        return str(self.link_path) if self.link_path is not None else self.device

    @property
    def peer(self) -> Address:
        """The one peer of a serial line (the address frames from it are reported with)."""
        return (self.path, 0)

    def recvfrom(self, bufsize: int = PTY_READ_BYTES) -> tuple[bytes, Address]:
        """Bytes the client wrote; BlockingIOError when there are none."""
        if self._master is None:
            raise OSError(errno.EBADF, "pty is closed")
        data = os.read(self._master, min(bufsize, PTY_READ_BYTES))
        if not data:
            raise BlockingIOError(errno.EAGAIN, "nothing to read")
        return data, self.peer

    def sendto(self, data: bytes, address: Address | None = None) -> int:
        """Write one frame whole, or drop it (BlockingIOError / OSError) without blocking."""
        master = self._master
        if master is None:
            raise OSError(errno.EBADF, "pty is closed")
        if self._pending:
            self._pending = self._pending[self._write(master, self._pending) :]
            if self._pending:
                return self._drop(data, BlockingIOError(errno.EAGAIN, "pty buffer full"))
        try:
            written = os.write(master, data)
        except OSError as exc:
            return self._drop(data, exc)
        self.bytes_written += written
        if written < len(data):
            self._pending = data[written:]
        return len(data)

    def _write(self, master: int, data: bytes) -> int:
        try:
            written = os.write(master, data)
        except OSError:
            return 0
        self.bytes_written += written
        return written

    def _drop(self, data: bytes, exc: OSError) -> int:
        self.dropped_frames += 1
        self.dropped_bytes += len(data)
        if self.dropped_frames == 1 or self.dropped_frames % 10_000 == 0:
            logger.info(
                "serial port %s: %d frame(s) dropped, nobody reading (%s)",
                self.path,
                self.dropped_frames,
                exc.strerror or exc,
            )
        raise exc

    def fileno(self) -> int:
        """The master end (readable when the client wrote)."""
        if self._master is None:
            raise OSError(errno.EBADF, "pty is closed")
        return self._master

    def getsockname(self) -> Address:
        """(path a client opens, 0)."""
        return self.peer

    def close(self) -> None:
        """Close both ends and remove the symlink. Safe to call twice."""
        for fd in (self._master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError as exc:
                    logger.debug("closing pty fd %d: %s", fd, exc)
        self._master = self._slave = None
        if self.link_path is not None and self.link_path.is_symlink():
            try:
                self.link_path.unlink()
            except OSError as exc:
                logger.debug("removing %s: %s", self.link_path, exc)
