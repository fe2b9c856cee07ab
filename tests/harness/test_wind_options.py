"""The command line's wind options: syntax, clear errors, and the WindConfig they build."""

from __future__ import annotations

import pytest
import typer
from typer.testing import CliRunner

from harness.cli import app
from harness.options.wind import parse_gusts, parse_turbulence, parse_wind, wind_config
from sitl.physics.wind import TURBULENCE_W20_M_S


def test_wind_speed_at_direction_with_optional_vertical():
    assert parse_wind("5@270") == (5.0, 270.0, 0.0)
    assert parse_wind("3.5@-90,0.5") == (3.5, 270.0, 0.5)
    assert parse_wind(None) is None


@pytest.mark.parametrize("spec", ["5", "x@270", "5@west", "-2@90", "5@270,up", "5@nan"])
def test_bad_wind_names_the_option_and_the_syntax(spec):
    with pytest.raises(typer.BadParameter) as err:
        parse_wind(spec)
    assert err.value.param_hint == "--wind"
    assert repr(spec) in str(err.value)


def test_turbulence_levels_and_w20():
    assert parse_turbulence("Light") == TURBULENCE_W20_M_S["light"]
    assert parse_turbulence("off") == 0.0
    assert parse_turbulence("12") == 12.0
    with pytest.raises(typer.BadParameter, match="light, moderate, severe"):
        parse_turbulence("medium")


def test_gusts_peak_and_options():
    assert parse_gusts("4") == (4.0, 20.0, 30.0)
    assert parse_gusts("4,length=30,every=20") == (4.0, 30.0, 20.0)
    for bad in ("4,len=3", "4,every=0", "x"):
        with pytest.raises(typer.BadParameter):
            parse_gusts(bad)


def test_no_wind_options_is_calm_air_and_options_combine():
    assert wind_config(None, 0.0, None) is None
    cfg = wind_config(parse_wind("8@270"), parse_turbulence("light"), parse_gusts("3,every=10"))
    assert cfg is not None
    assert (cfg.speed_m_s, cfg.from_deg, cfg.gust_peak_m_s, cfg.gust_interval_s) == (
        8.0,
        270.0,
        3.0,
        10.0,
    )
    assert cfg.turbulence_w20_m_s == TURBULENCE_W20_M_S["light"]


def test_up_reports_a_bad_wind_as_a_usage_error_and_help_shows_an_example():
    runner = CliRunner()
    result = runner.invoke(app, ["up", "--wind", "5", "--duration", "0.1"])
    assert result.exit_code == 2
    assert "--wind" in result.output and "5@270" in result.output
    help_text = runner.invoke(app, ["up", "--help"], terminal_width=200).output
    assert "--wind 5@270" in help_text
