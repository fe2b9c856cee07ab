"""swarmsitl up --world FILE --launch-area NAME."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.run.ports import RunPorts, free_ports
from worlds.examples import example_path

pytestmark = pytest.mark.sockets


def _up(tmp_path, *args: str, ports: RunPorts | None = None):
    """``swarmsitl up`` briefly, on ``ports`` (fresh ones from the suite's allocator if None)."""
    ports = ports or free_ports(vehicles=2)
    base = ["up", "--speed", "50", "--duration", "0.3", "--out", str(tmp_path)]
    base += ["--gcs-port", "0", "--no-camera", "--payload-port", "0", "--video-port", "0"]
    base += ["--sdk-port", str(ports.sdk), "--listen-port", str(ports.listen)]
    base += ["--mocap-port", str(ports.mocap)]
    return CliRunner().invoke(app, [*base, *args])


def _flat(text: str) -> str:
    return " ".join(text.split())


def test_offshore_vehicles_start_on_the_helideck_in_the_worlds_wind(tmp_path):
    result = _up(tmp_path, "-n", "2", "--world", str(example_path("offshore")))
    assert result.exit_code == 0, result.output
    out = _flat(result.output)
    assert "launch area helideck" in out
    assert "wind 6 m/s from 314 deg, turbulence W20 7.8 m/s" in out
    assert out.count(", 520.2 │") == 2  # home: 488 m + the 32 m deck + the resting height


def test_wind_options_replace_the_worlds_wind(tmp_path):
    result = _up(tmp_path, "--world", str(example_path("offshore")), "--wind", "3@90")
    assert result.exit_code == 0, result.output
    assert "wind 3 m/s from 90 deg, turbulence W20 0.0 m/s" in _flat(result.output)


def test_a_gps_denied_world_prints_each_vehicles_bridge(tmp_path):
    args = ["-n", "2", "--spacing", "1.2", "--world", str(example_path("indoor"))]
    ports = free_ports(vehicles=2)
    result = _up(tmp_path, *args, ports=ports)
    assert result.exit_code == 0, result.output
    out = _flat(result.output)
    assert "launch area safe_point" in out and "motion capture: 50 Hz" in out
    for i in range(2):
        assert (
            f"python -m companion.scripts.mocap_bridge --vehicle {i} --listen "
            f"127.0.0.1:{ports.mocap + i} --mavlink udpout:127.0.0.1:{ports.listen + i}"
        ) in out


def test_a_bad_world_file_prints_file_line_and_exits_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: offshore\nseed: 7\nbuildng_height_m: 3\n")
    result = _up(tmp_path, "--world", str(bad))
    assert result.exit_code == 2
    assert f"{bad}:3: buildng_height_m: unknown key" in _flat(result.output)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--world", str(example_path("offshore")), "--launch-area", "pier"], "'pier'"),
        (["--world", str(example_path("indoor")), "-n", "4"], "'safe_point' (radius 2 m)"),
        (["--launch-area", "helideck"], "needs --world"),
    ],
)
def test_bad_launch_areas_are_refused_with_a_reason(tmp_path, args, message):
    result = _up(tmp_path, *args)
    assert result.exit_code == 2
    assert message in _flat(result.output)


def test_help_shows_a_world_example():
    result = CliRunner().invoke(app, ["up", "--help"])
    assert result.exit_code == 0
    assert "--world" in result.output and "--launch-area helideck" in _flat(result.output)
