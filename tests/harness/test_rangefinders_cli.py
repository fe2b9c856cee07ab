"""``swarmsitl up --no-rangefinders`` switches the range finders off (no DISTANCE_SENSOR)."""

from __future__ import annotations

import socket

import pytest
from pymavlink.dialects.v20 import common as mavlink2
from typer.testing import CliRunner

from harness.cli import app

pytestmark = pytest.mark.sockets


def _distance_sensors_sent(tmp_path, *flags: str) -> set[int]:
    """Run ``up`` for 1 simulated second; ids of the DISTANCE_SENSOR its onboard link sent."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sink:
        sink.bind(("127.0.0.1", 0))  # the OS picks the port the vehicle streams to
        sink.setblocking(False)
        sdk_port = str(sink.getsockname()[1])
        # No camera: its payload link and stream would bind the default ports (14030, 5600),
        # which the README's demo, run verbatim by another test, binds too.
        args = ["up", "--speed", "50", "--duration", "1", "--gcs-port", "0", "--no-camera"]
        args += ["--out", str(tmp_path), "--sdk-port", sdk_port, "--listen-port", "0", *flags]
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 0, result.output
        parser = mavlink2.MAVLink(None)
        ids = set()
        while True:
            try:
                data = sink.recv(65535)
            except BlockingIOError:
                break
            ids |= {
                m.id for m in parser.parse_buffer(data) or [] if m.get_type() == "DISTANCE_SENSOR"
            }
    return ids


@pytest.mark.parametrize(
    ("flags", "expected"), [((), set(range(7))), (("--no-rangefinders",), set())]
)
def test_no_rangefinders_flag(tmp_path, flags, expected):
    assert _distance_sensors_sent(tmp_path, *flags) == expected


def test_help_documents_the_flag():
    result = CliRunner().invoke(app, ["up", "--help"])
    assert "--no-rangefinders" in result.output
