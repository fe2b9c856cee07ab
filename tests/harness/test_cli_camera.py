"""``swarmsitl up`` camera options: parsed into one CameraSpec, refused with a reason, announced."""

import pytest
import typer
from typer.testing import CliRunner

from harness.cli import app
from harness.commands.up_options import camera_override
from harness.run.ports import free_port_block
from sitl.vehicles.multirotor import load_airframe

pytestmark = pytest.mark.sockets


def test_no_camera_option_keeps_the_airframes_cameras():
    assert camera_override(("typhoon_h480",), None, None, None, None, 500.0) is None


def test_options_modify_each_airframes_camera_and_give_none_to_others():
    typhoon = load_airframe("typhoon_h480").camera
    frames = ("x500", "typhoon_h480", "typhoon_h480")
    x500, spec, again = camera_override(frames, "forward", "640x480", 5.0, 90.0, 500.0)
    assert x500 is None and again == spec
    assert (spec.width_px, spec.height_px, spec.rate_hz, spec.hfov_deg) == (640, 480, 5.0, 90.0)
    assert spec.pitch_deg == 0.0
    assert spec.position_frd_m == typhoon.position_frd_m
    [down] = camera_override(("typhoon_h480",), "down", None, None, None, 500.0)
    assert down.pitch_deg == -90.0 and down.width_px == typhoon.width_px


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        ((None, "640", None, None), "WIDTHxHEIGHT"),
        ((None, "0x480", None, None), "width_px"),
        ((None, None, 7.0, None), "divide"),
        ((None, None, 1000.0, None), "divide"),
        ((None, None, None, 200.0), "hfov_deg"),
    ],
)
def test_bad_camera_options_are_refused_with_a_reason(args, reason):
    with pytest.raises(typer.BadParameter, match=reason):
        camera_override(("typhoon_h480",), *args, 500.0)


def test_a_bad_mount_is_a_usage_error():
    result = CliRunner().invoke(app, ["up", "--camera-mount", "sideways", "--duration", "0.1"])
    assert result.exit_code == 2
    assert "down" in result.output and "forward" in result.output


def test_up_prints_the_stream_uri(tmp_path):
    port = free_port_block(1)
    args = ["up", "--speed", "50", "--duration", "0.5", "--gcs-port", "0", "--sdk-port", "0"]
    args += ["--listen-port", "0", "--out", str(tmp_path / "run"), "--payload-port", "0"]
    args += ["--video-port", str(port), "--camera-size", "160x120", "--camera-hz", "5"]
    result = CliRunner().invoke(app, args, terminal_width=200)
    assert result.exit_code == 0, result.output
    assert f"http://127.0.0.1:{port}/video.mjpg" in result.output
    assert "160x120, 5 Hz" in result.output
