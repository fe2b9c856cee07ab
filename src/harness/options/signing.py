"""``swarmsitl up --signing-key FILE / --signing-passphrase TEXT``: MAVLink 2 signing of the links.

Turns the options into the 32-byte key of ``SimulationConfig.signing_key`` (the file format
and the passphrase derivation are :mod:`autopilot_emu.mavlink.signing`'s), and says when the
links listen beyond this machine without a key.
"""

from __future__ import annotations

import ipaddress
from pathlib import Path

from autopilot_emu.mavlink.signing import SigningKeyError, key_from_passphrase, load_key_file

SIGNING_KEY_HELP = (
    "sign every MAVLink frame of the vehicles' links and accept only signed ones, with the "
    "32-byte key in FILE: 64 hex characters or 32 raw bytes (docs/cli.md#mavlink-signing; "
    "e.g. openssl rand -hex 32 > key.hex; swarmsitl up --bind 0.0.0.0 --signing-key key.hex)"
)
SIGNING_PASSPHRASE_HELP = (
    "as --signing-key, with the key SHA-256(TEXT), as MAVProxy's `signing key TEXT` "
    "(e.g. --signing-passphrase 'correct horse battery staple')"
)


def signing_key(key_file: Path | None, passphrase: str | None) -> bytes | None:
    """The signing key of the options (None: neither given).

    Raises:
        ValueError: both given, an empty passphrase, or a key file that cannot be read or holds
            no key (the message says which and why).
    """
    if key_file is not None and passphrase is not None:
        raise ValueError("give --signing-key or --signing-passphrase, not both")
    try:
        if key_file is not None:
            return load_key_file(key_file)
        if passphrase is not None:
            return key_from_passphrase(passphrase)
    except SigningKeyError as exc:
        raise ValueError(str(exc)) from exc
    return None


def is_loopback(bind_addr: str) -> bool:
    """Whether ``bind_addr`` keeps the links on this machine (127.0.0.0/8, ::1, localhost)."""
    if bind_addr == "localhost":
        return True
    try:
        return ipaddress.ip_address(bind_addr).is_loopback
    except ValueError:  # a host name: it may resolve to an interface on the network
        return False


def unauthenticated_warning(bind_addr: str, key: bytes | None) -> str | None:
    """The warning for links that listen beyond this machine without a key; None if none due."""
    if key is not None or is_loopback(bind_addr):
        return None
    return (
        f"the vehicles' MAVLink links listen on {bind_addr} without signing: anyone on the "
        "network can arm, fly and reconfigure them (unauthenticated commands). Give "
        "--signing-key FILE or --signing-passphrase TEXT to accept only signed frames."
    )
