"""The command line's wind options: ``--wind``, ``--turbulence``, ``--gusts`` -> ``WindConfig``.

Syntax (every number in SI units):

* ``--wind SPEED@FROM[,UP]``: SPEED m/s blowing from FROM degrees clockwise from true north
  (meteorological convention: ``5@270`` is a 5 m/s west wind, blowing towards the east); UP is
  an optional vertical wind, m/s, positive up.
* ``--turbulence LEVEL``: Dryden turbulence (MIL-F-8785C, low altitude): ``off``, ``light``,
  ``moderate``, ``severe`` (W20 = 15 / 30 / 45 kt), or a number: W20 in m/s, the wind speed
  6 m above ground that sets the intensity.
* ``--gusts PEAK[,length=M][,every=S]``: "1 - cosine" gusts adding up to PEAK m/s, building up
  over M metres (default 20), one every S seconds on average (default 30).
"""

from __future__ import annotations

import math

import typer

from sitl.physics.wind import TURBULENCE_W20_M_S, WindConfig

WIND_HELP = (
    "steady wind SPEED@FROM[,UP]: m/s, from degrees clockwise from north, optional m/s up "
    "(e.g. 5@270: 5 m/s from the west)"
)
TURBULENCE_HELP = (
    "Dryden turbulence: off, light, moderate, severe (MIL-F-8785C) or W20 in m/s (wind 6 m above "
    "ground)"
)
GUSTS_HELP = (
    "1-cosine gusts PEAK[,length=M][,every=S]: peak m/s, build-up length m (20), mean seconds "
    "between gusts (30); e.g. 4,length=30,every=20"
)


def _number(text: str, what: str, spec: str, option: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise typer.BadParameter(
            f"{spec!r}: {what} {text.strip()!r} is not a number", param_hint=option
        )
    return value


def parse_wind(spec: str | None) -> tuple[float, float, float] | None:
    """``SPEED@FROM[,UP]`` -> (speed m/s, from degrees in [0, 360), up m/s); None passes."""
    if spec is None:
        return None
    head, _, up_text = spec.partition(",")
    speed_text, at, from_text = head.partition("@")
    if not at:
        raise typer.BadParameter(
            f"{spec!r}: expected SPEED@FROM_DEG[,UP], e.g. 5@270 (5 m/s from the west)",
            param_hint="--wind",
        )
    speed = _number(speed_text, "speed", spec, "--wind")
    if speed < 0.0:
        raise typer.BadParameter(f"{spec!r}: speed must be >= 0 m/s", param_hint="--wind")
    from_deg = _number(from_text, "direction", spec, "--wind") % 360.0
    up = _number(up_text, "vertical wind", spec, "--wind") if up_text else 0.0
    return speed, from_deg, up


def parse_turbulence(spec: str | None) -> float:
    """``off|light|moderate|severe|W20`` -> W20, m/s (0: off; None: off)."""
    if spec is None:
        return 0.0
    level = spec.strip().lower()
    if level == "off":
        return 0.0
    if level in TURBULENCE_W20_M_S:
        return TURBULENCE_W20_M_S[level]
    try:
        w20 = float(level)
    except ValueError:
        w20 = math.nan
    if not (math.isfinite(w20) and w20 >= 0.0):
        raise typer.BadParameter(
            f"{spec!r}: expected off, light, moderate, severe or W20 >= 0 in m/s",
            param_hint="--turbulence",
        )
    return w20


def parse_gusts(spec: str | None) -> tuple[float, float, float] | None:
    """``PEAK[,length=M][,every=S]`` -> (peak m/s, length m, mean interval s); None passes."""
    if spec is None:
        return None
    calm = WindConfig()
    peak_text, *options = spec.split(",")
    peak = _number(peak_text, "peak", spec, "--gusts")
    values = {"length": calm.gust_length_m, "every": calm.gust_interval_s}
    for option in options:
        key, eq, text = option.partition("=")
        key = key.strip().lower()
        if not eq or key not in values:
            raise typer.BadParameter(
                f"{spec!r}: {option!r} is not length=M or every=S (e.g. 4,length=30,every=20)",
                param_hint="--gusts",
            )
        values[key] = _number(text, key, spec, "--gusts")
    if peak < 0.0 or values["length"] <= 0.0 or values["every"] <= 0.0:
        raise typer.BadParameter(
            f"{spec!r}: peak must be >= 0 m/s, length and every > 0", param_hint="--gusts"
        )
    return peak, values["length"], values["every"]


def wind_config(
    wind: tuple[float, float, float] | None,
    turbulence_w20_m_s: float,
    gusts: tuple[float, float, float] | None,
) -> WindConfig | None:
    """The world's wind from the parsed options; None when all are off (calm air)."""
    if wind is None and turbulence_w20_m_s == 0.0 and (gusts is None or gusts[0] == 0.0):
        return None
    calm = WindConfig()
    speed, from_deg, up = wind if wind is not None else (0.0, 0.0, 0.0)
    peak, length, every = (
        gusts if gusts is not None else (0.0, calm.gust_length_m, calm.gust_interval_s)
    )
    return WindConfig(
        speed_m_s=speed,
        from_deg=from_deg,
        up_m_s=up,
        turbulence_w20_m_s=turbulence_w20_m_s,
        gust_peak_m_s=peak,
        gust_length_m=length,
        gust_interval_s=every,
    )
