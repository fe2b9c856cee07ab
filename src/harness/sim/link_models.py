"""Which link model a vehicle's MAVLink paths run through (``swarmsitl up --link/--gcs-link``).

The companion <-> autopilot path of a real vehicle is a UART at 921600 baud (Pixhawk TELEM2);
the ground-station path a SiK telemetry radio at 57600 baud. A link model is a preset of the
link file (``sitl/links/presets.yaml``, or the user's ``--links FILE`` merged over it): ``uart``,
``sik``, ``wifi``, ``wired``, ``lte``, ... ; ``none`` is plain UDP. :func:`mavlink_shaper` is the
one place that turns a name into the two directions of a vehicle's path.

A path behind a serial preset (bits_per_byte > 8: a UART or a radio's serial side) also gets
PX4's data-rate limit: ``mavlink start`` without ``-r`` (MAV_x_RATE = 0) uses half the line's
byte rate, baud / 20 B/s, and scales its streams to fit (see ``EndpointConfig.datarate_bytes_s``).
"""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

from harness.options.suggest import did_you_mean
from sitl.links.config import LinksConfig
from sitl.links.network import mavlink_channels
from sitl.links.shaper import MavlinkLinkShaper

NO_LINK = "none"

ONBOARD = 0
"""Path index of the companion <-> autopilot link."""
GCS = 1
"""Path index of the ground-station link."""
SERIAL = 2
"""Path index of the serial port (``up --serial``: TELEM2 to a companion)."""
PATH_NAMES = ("onboard", "gcs", "serial")


@lru_cache(maxsize=8)
def links_config(path: Path | None = None, inline: str | None = None) -> LinksConfig:
    """The shipped presets, the user's link file and ``inline`` merged over them, in turn.

    ``inline``: a link file's mapping as JSON text (a scenario's ``links.presets`` and
    ``links.classes``; text, so that the result is cached per path and mapping).
    """
    return LinksConfig.load(path, None if inline is None else json.loads(inline))


def link_models(config: LinksConfig | None = None) -> tuple[str, ...]:
    """Names ``--link`` / ``--gcs-link`` accept: ``none`` and every preset of the link file."""
    config = links_config() if config is None else config
    return (NO_LINK, *sorted(config.presets))


def check_link_model(name: str, field: str, config: LinksConfig | None = None) -> str:
    """``name`` if it is ``none`` or a preset, else a ValueError naming ``field``."""
    known = link_models(config)
    if name not in known:
        raise ValueError(f"{field}: unknown link model {name!r}{did_you_mean(name, known)}")
    return name


def mavlink_shaper(
    name: str, seed: int, vehicle_index: int, path: int, config: LinksConfig | None = None
) -> MavlinkLinkShaper | None:
    """The shaper of one vehicle's path behind preset ``name``; None for ``none``.

    Each vehicle, path and direction draws from its own generator (seeded from the run's seed
    and a stable label), so adding a link never shifts the world's random draws.
    """
    config = links_config() if config is None else config
    if check_link_model(name, "link", config) == NO_LINK:
        return None
    to_vehicle, from_vehicle = mavlink_channels(name, config, seed, vehicle_index, PATH_NAMES[path])
    return MavlinkLinkShaper(to_vehicle, from_vehicle)


def datarate_bytes_s(name: str, config: LinksConfig | None = None) -> float:
    """PX4's default data-rate limit of a MAVLink instance on the path, B/s (0: none).

    Serial presets: baud / 20 (``mavlink start`` with MAV_x_RATE = 0, half the line's bytes per
    second); packet links (WiFi, wired, LTE): 0, as PX4's UDP instances run far above need.
    """
    if name == NO_LINK:
        return 0.0
    config = links_config() if config is None else config
    params = config.preset(name).up
    if params.bits_per_byte <= 8:
        return 0.0
    return params.rate_bps / params.bits_per_byte / 2.0


def describe(name: str, config: LinksConfig | None = None) -> str:
    """Short label of a link model for the endpoint table, e.g. ``uart 921600 Bd 8N1``."""
    if name == NO_LINK:
        return "direct"
    config = links_config() if config is None else config
    params = config.preset(name).up
    if params.bits_per_byte == 10:
        return f"{name} {params.rate_bps:.0f} Bd 8N1"
    return f"{name} {params.rate_bps / 1e6:g} Mb/s"
