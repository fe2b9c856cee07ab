"""Which link model a vehicle's MAVLink paths run through (``swarmsitl up --link/--gcs-link``).

The companion <-> autopilot path of a real vehicle is a UART at 921600 baud; the ground-station
path a SiK telemetry radio at 57600 baud. Each name of :data:`LINK_MODELS` selects the
parameters of both directions of such a path; :func:`mavlink_channels` is the one place that
turns a name into channels (the link presets file will take over there).

The parameters below are stand-ins until the presets YAML of ``sitl.links`` (with its
citations) lands; only the serial rates are exact (921600 and 57600 baud, 8N1 framing: 10 bits
on the wire per byte).
"""

from __future__ import annotations

import math

import numpy as np

from sitl.links.channel import LinkChannel
from sitl.links.params import LatencyParams, LinkParams, LossParams
from sitl.links.shaper import MavlinkLinkShaper

NO_LINK = "none"
LINK_MODELS: tuple[str, ...] = (NO_LINK, "uart", "sik", "wifi", "wired")
"""Names accepted by ``--link`` / ``--gcs-link`` and ``SimulationConfig.onboard_link/gcs_link``."""

ONBOARD = 0
"""Path index of the companion <-> autopilot link (random streams per path)."""
GCS = 1
"""Path index of the ground-station link."""

_STREAM_KEY = 0x6D6C6E6B
"""First word of the link generators' spawn key: clear of every generator the world spawns."""


def uart_params() -> LinkParams:
    """Pixhawk TELEM2 <-> Pi UART: 921600 baud 8N1 = 92160 B/s, a byte stream, in order.

    queue_bytes (3000) stands for the serial transmit buffer; a frame that does not fit is
    dropped, as PX4's mavlink module drops a message when the TX buffer lacks room.
    """
    return LinkParams(
        kind="uart",
        rate_bps=921_600.0,
        bits_per_byte=10,
        overhead_bytes=0,
        queue_bytes=3000,
        max_datagram_bytes=3000,
        in_order=True,
    )


def sik_params() -> LinkParams:
    """SiK telemetry radio at 57600 baud 8N1 (5760 B/s), in order.

    The latency stands for the radio's TDM: a byte waits for its side's transmit window (a
    few ms fixed, then up to a window of tens of ms); 1 % loss stands for a radio at
    moderate range. Stand-ins until the presets file.
    """
    return LinkParams(
        kind="sik",
        rate_bps=57_600.0,
        bits_per_byte=10,
        overhead_bytes=0,
        queue_bytes=2048,
        max_datagram_bytes=2048,
        latency=LatencyParams(base_s=0.005, jitter="exponential", jitter_s=0.03),
        loss=LossParams(mean_loss=0.01),
        in_order=True,
    )


def wifi_params() -> LinkParams:
    """802.11ac on a Pi 5, one hop: ~200 Mb/s goodput, ~1-2 ms latency (stand-in)."""
    return LinkParams(
        kind="wifi",
        rate_bps=200e6,
        overhead_bytes=28,
        latency=LatencyParams(base_s=0.001, jitter="exponential", jitter_s=0.001),
    )


def wired_params() -> LinkParams:
    """Gigabit Ethernet: 0.1 ms, lossless (stand-in)."""
    return LinkParams(
        kind="wired",
        rate_bps=1e9,
        overhead_bytes=28,
        latency=LatencyParams(base_s=0.0001),
        range_m=math.inf,
    )


_PARAMS = {"uart": uart_params, "sik": sik_params, "wifi": wifi_params, "wired": wired_params}


def check_link_model(name: str, field: str) -> str:
    """``name`` if it is one of :data:`LINK_MODELS`, else a ValueError naming ``field``."""
    if name not in LINK_MODELS:
        raise ValueError(f"{field}: unknown link model {name!r}; known: {', '.join(LINK_MODELS)}")
    return name


def link_rng(seed: int, path: int, vehicle_index: int, direction: int) -> np.random.Generator:
    """The generator of one direction of one vehicle's path, independent of all others.

    Built from the scenario seed with its own spawn key, so adding a link never shifts the
    world's random draws (nor another link's).
    """
    sequence = np.random.SeedSequence(seed, spawn_key=(_STREAM_KEY, path, vehicle_index, direction))
    return np.random.default_rng(sequence)


def mavlink_channels(
    name: str, seed: int, vehicle_index: int, path: int
) -> tuple[LinkChannel, LinkChannel]:
    """(to_vehicle, from_vehicle) channels of link model ``name`` for one vehicle's path.

    The seam the link presets will replace (``sitl.links`` ``mavlink_channels(preset, config,
    seed, vehicle_index)``): nothing else builds MAVLink channels.
    """
    params = _PARAMS[check_link_model(name, "link")]()
    return (
        LinkChannel(params, link_rng(seed, path, vehicle_index, 0)),
        LinkChannel(params, link_rng(seed, path, vehicle_index, 1)),
    )


def mavlink_shaper(name: str, seed: int, vehicle_index: int, path: int) -> MavlinkLinkShaper | None:
    """The shaper of one vehicle's path behind link model ``name``; None for ``none``."""
    if check_link_model(name, "link") == NO_LINK:
        return None
    return MavlinkLinkShaper(*mavlink_channels(name, seed, vehicle_index, path))


def describe(name: str) -> str:
    """Short label of a link model for the endpoint table, e.g. ``uart 921600 Bd``."""
    if name == NO_LINK:
        return "direct"
    params = _PARAMS[name]()
    if params.bits_per_byte == 10:
        return f"{name} {params.rate_bps:.0f} Bd 8N1"
    return f"{name} {params.rate_bps / 1e6:g} Mb/s"
