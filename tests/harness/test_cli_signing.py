"""``swarmsitl up --signing-key / --signing-passphrase / --bind``: options, errors, warnings."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.options.signing import is_loopback, signing_key, unauthenticated_warning

pytestmark = pytest.mark.sockets

QUICK = ["up", "--speed", "50", "--duration", "0.2", "--gcs-port", "0", "--no-camera"]
QUICK += ["--sdk-port", "0", "--listen-port", "0"]


def _flat(output: str) -> str:
    """The output without the line breaks and box drawing of rich's wrapping."""
    return " ".join(output.replace("│", " ").split())


def test_help_explains_the_signing_options_with_examples():
    result = CliRunner().invoke(app, ["up", "--help"], env={"COLUMNS": "240"})
    assert result.exit_code == 0
    flat = _flat(result.output)
    assert "--signing-key" in flat and "--signing-passphrase" in flat
    assert "64 hex characters or 32 raw bytes" in flat
    assert "Example: swarmsitl up --bind 0.0.0.0 --signing-key key.hex" in flat


@pytest.mark.parametrize(
    ("content", "reason"),
    [(b"not a key", "expected 64 hexadecimal characters"), (b"00" * 32, "all-zero key")],
)
def test_bad_key_file_exits_2_with_a_clear_message(tmp_path, content, reason):
    key_file = tmp_path / "key.hex"
    key_file.write_bytes(content)
    result = CliRunner().invoke(
        app, [*QUICK, "--out", str(tmp_path / "run"), "--signing-key", str(key_file)]
    )
    assert result.exit_code == 2
    flat = _flat(result.output)
    assert "error:" in flat and reason in flat and "key.hex" in flat
    assert not (tmp_path / "run").exists()  # refused before anything started


def test_missing_key_file_and_conflicting_options_exit_2(tmp_path):
    missing = CliRunner().invoke(app, [*QUICK, "--signing-key", str(tmp_path / "nope")])
    assert missing.exit_code == 2 and "cannot read the signing key file" in _flat(missing.output)
    key_file = tmp_path / "key.hex"
    key_file.write_text("ab" * 32)
    both = CliRunner().invoke(
        app, [*QUICK, "--signing-key", str(key_file), "--signing-passphrase", "x"]
    )
    assert both.exit_code == 2 and "not both" in _flat(both.output)


def test_bind_beyond_loopback_without_a_key_warns(tmp_path):
    result = CliRunner().invoke(app, [*QUICK, "--out", str(tmp_path), "--bind", "0.0.0.0"])
    assert result.exit_code == 0, result.output
    flat = _flat(result.output)
    assert "warning:" in flat and "unauthenticated commands" in flat


def test_bind_beyond_loopback_with_a_passphrase_signs_without_warning(tmp_path):
    args = [*QUICK, "--out", str(tmp_path), "--bind", "0.0.0.0"]
    result = CliRunner().invoke(app, [*args, "--signing-passphrase", "swarm"])
    assert result.exit_code == 0, result.output
    flat = _flat(result.output)
    assert "unauthenticated" not in flat
    assert "MAVLink 2 signing: every link signs its frames" in flat


@pytest.mark.parametrize(
    ("bind", "local"),
    [
        ("127.0.0.1", True),
        ("127.0.1.1", True),
        ("::1", True),
        ("localhost", True),
        ("0.0.0.0", False),
        ("192.168.1.20", False),
        ("drone-pi.local", False),
    ],
)
def test_which_bind_addresses_leave_the_machine(bind, local):
    assert is_loopback(bind) is local
    assert (unauthenticated_warning(bind, None) is None) is local
    assert unauthenticated_warning(bind, bytes(range(32))) is None


def test_passphrase_and_key_file_give_the_same_key_for_the_same_secret(tmp_path):
    import hashlib

    key_file = tmp_path / "key.hex"
    key_file.write_text(hashlib.sha256(b"swarm").hexdigest() + "\n")
    assert signing_key(key_file, None) == signing_key(None, "swarm")
    assert signing_key(None, None) is None
