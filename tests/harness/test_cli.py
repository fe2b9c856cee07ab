"""Every CLI command documents itself with an example."""

import pytest
from typer.testing import CliRunner

from harness.cli import app


@pytest.mark.parametrize("args", [["--help"], ["up", "--help"], ["demo", "--help"]])
def test_help_has_example(args):
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0
    if args != ["--help"]:
        assert "Example:" in result.output


def test_up_rejects_bad_vehicle_count():
    result = CliRunner().invoke(app, ["up", "--vehicles", "0"])
    assert result.exit_code != 0
