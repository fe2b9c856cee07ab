"""PyBullet, imported without its build-time banner.

PyBullet's C extension prints ``pybullet build time: <date>`` when it is first imported, from C
(``printf``/``fprintf``), so neither ``contextlib.redirect_stdout`` nor Python's ``sys.stdout``
sees it; every ``swarmsitl`` command printed it. :func:`quiet_import` points file descriptors 1
and 2 at /dev/null for the length of that first import and flushes the C streams before putting
them back. Every module of the project imports PyBullet from here (``from
sitl.physics.bullet_import import pybullet as p``); tests/sitl/physics/test_bullet_import.py
checks that none imports it directly.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib
import os
import sys
from types import ModuleType

BANNER = "pybullet build time"
"""Start of the line PyBullet prints on import."""


def _flush_c_streams() -> None:
    """``fflush(NULL)``: the banner leaves C's buffers while the descriptors point at /dev/null."""
    with contextlib.suppress(OSError, AttributeError):  # no C library handle: nothing to flush
        ctypes.CDLL(None).fflush(None)


def quiet_import() -> ModuleType:
    """Import ``pybullet`` with fds 1 and 2 on /dev/null; the module.

    Once imported, PyBullet is in ``sys.modules`` and later imports print nothing, so only the
    first import is silenced. Python's own buffers are flushed first, so nothing written before
    is lost; an ImportError is raised after the descriptors are restored, so it is seen.
    """
    if "pybullet" in sys.modules:
        return sys.modules["pybullet"]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    try:
        saved = (os.dup(1), os.dup(2))
    except OSError:  # fd 1 or 2 closed (a daemon): nowhere to print the banner either
        return importlib.import_module("pybullet")
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        module = importlib.import_module("pybullet")
        _flush_c_streams()
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)
    return module


pybullet = quiet_import()
"""The ``pybullet`` module (``from sitl.physics.bullet_import import pybullet as p``)."""
