"""``swarmsitl up --frame``: one airframe for all vehicles or one per vehicle."""

import pytest
import typer
from typer.testing import CliRunner

from harness.cli import app
from harness.options.world import parse_frames

pytestmark = pytest.mark.sockets


def test_frame_is_one_for_all_or_one_per_vehicle():
    """A single name is every vehicle's; a list must have one name per vehicle."""
    assert parse_frames("x500", 3) == ("x500",)
    assert parse_frames("typhoon_h480, x500,x500", 3) == ("typhoon_h480", "x500", "x500")
    with pytest.raises(typer.BadParameter, match="one per vehicle \\(3\\)"):
        parse_frames("typhoon_h480,x500", 3)
    with pytest.raises(typer.BadParameter, match="unknown airframe 'x5000'"):
        parse_frames("x5000", 1)


def test_up_flies_mixed_frames_and_lists_them(tmp_path):
    """``up --frame typhoon_h480,x500`` starts a hexacopter and a quad and names them."""
    out = tmp_path / "run"
    args = ["up", "-n", "2", "--frame", "typhoon_h480,x500", "--speed", "50", "--duration", "1"]
    args += ["--no-camera"]
    args += ["--gcs-port", "0", "--sdk-port", "0", "--listen-port", "0", "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "typhoon_h480" in result.output and "x500" in result.output
    assert (out / "truth.csv").stat().st_size > 0


def test_up_refuses_a_frame_count_that_does_not_match():
    """Two frames for three vehicles is refused before anything starts."""
    result = CliRunner().invoke(app, ["up", "-n", "3", "--frame", "typhoon_h480,x500"])
    assert result.exit_code != 0
    assert "--frame" in result.output
