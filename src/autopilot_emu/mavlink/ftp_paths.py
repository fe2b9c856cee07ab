"""Maps the paths MAVLink FTP clients send onto one vehicle's root directory, and nowhere else.

PX4 prepends its root (``PX4_ROOTFSDIR``) to whatever the client sends and lets ``..`` walk out
of it. Here every path is confined to the root:

* a path is the C string at the start of the request's data (up to the first NUL, at most
  238 bytes, as PX4's ``_data_as_cstring``), bytes decoded as the OS would (UTF-8,
  undecodable bytes kept as surrogates);
* leading slashes are dropped: ``/log``, ``log`` and ``//log`` are ``<root>/log``; ``""`` and
  ``/`` are the root itself;
* ``.`` and empty components are dropped; ``..`` steps up, but never above the root: a path
  that would leave the root is refused with FileProtected (what PX4 on a flight controller
  answers for writes outside its SD card);
* the path is then resolved through symbolic links; one that resolves outside the root is
  refused with FileProtected too;
* paths starting with ``@`` name ArduPilot's virtual files (``@PARAM/param.pck``,
  ``@MISSION/mission.dat``); PX4 has none, they are refused with FileNotFound.
"""

from __future__ import annotations

import os
from pathlib import Path

from autopilot_emu.mavlink.ftp_codec import MAX_DATA_LENGTH, ErrorCode, FtpPayload

MAX_PATH_BYTES = MAX_DATA_LENGTH - 1
"""Longest path a request can carry, bytes (PX4 NUL-terminates data[238])."""


class PathRefused(Exception):
    """A client path that must not be touched; ``code`` is the NAK to answer with."""

    def __init__(self, code: ErrorCode, path: str) -> None:
        super().__init__(f"{code.name}: {path!r}")
        self.code = code


def request_strings(payload: FtpPayload) -> list[bytes]:
    """The NUL-separated strings of a request's data (PX4 reads at most 238 bytes)."""
    return payload.data[: min(payload.size, MAX_PATH_BYTES)].split(b"\0")


class FtpRoot:
    """The directory a vehicle's FTP server serves; resolves client paths inside it.

    Args:
        root: an existing directory.

    Raises:
        ValueError: ``root`` is not a directory.
    """

    def __init__(self, root: Path) -> None:
        real = Path(os.path.realpath(root))
        if not real.is_dir():
            raise ValueError(f"FTP root {root} is not a directory")
        self.path = real

    def resolve(self, raw: bytes, allow_root: bool = True) -> Path:
        """Client path bytes -> a path inside the root.

        Args:
            raw: the path as the client sent it (no NUL).
            allow_root: False for operations that would remove or move the root itself.

        Raises:
            PathRefused: ``@`` paths (FileNotFound); escapes, and the root where it is not
                allowed (FileProtected).
        """
        text = os.fsdecode(raw)
        if text.lstrip("/").startswith("@"):
            raise PathRefused(ErrorCode.FILE_NOT_FOUND, text)
        parts: list[str] = []
        for part in text.split("/"):
            if part in ("", "."):
                continue
            if part == "..":
                if not parts:
                    raise PathRefused(ErrorCode.FILE_PROTECTED, text)
                parts.pop()
            else:
                parts.append(part)
        if not parts and not allow_root:
            raise PathRefused(ErrorCode.FILE_PROTECTED, text)
        candidate = self.path.joinpath(*parts)
        real = Path(os.path.realpath(candidate))
        if real != self.path and self.path not in real.parents:
            raise PathRefused(ErrorCode.FILE_PROTECTED, text)
        if real == self.path and not allow_root:
            raise PathRefused(ErrorCode.FILE_PROTECTED, text)
        return candidate
