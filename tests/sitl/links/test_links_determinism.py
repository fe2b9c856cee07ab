"""Seeded link channels give the same drops and arrival times as the reference implementation.

Seeded runs are reproducible only if every channel draws the same numbers from its generator in
the same order and does the same arithmetic with them. The digests below were recorded from the
straightforward implementation (before the fast paths of the node-messaging hot loop): any
change to the order of the draws, to which datagrams consume one, or to the arithmetic of the
arrival times changes them, and with them every seeded run's report.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from sitl.links.channel import LinkChannel
from sitl.links.config import LinksConfig
from sitl.links.params import LatencyParams, LinkParams, LossParams, OutageParams

_CUSTOM = {
    "gamma-outages": LinkParams(
        kind="test",
        rate_bps=2e6,
        max_datagram_bytes=1400,
        queue_bytes=20_000,
        latency=LatencyParams(base_s=0.002, jitter="gamma", jitter_s=0.004, shape=3.0),
        loss=LossParams(
            model="gilbert_elliott", mean_loss=0.05, mean_burst_packets=4.0, loss_bad=0.5
        ),
        outages=OutageParams(windows_s=((1.0, 1.5),), mtbf_s=3.0, mttr_s=0.4),
        range_m=50.0,
        range_width_m=10.0,
    ),
    "ideal": LinkParams(kind="ideal"),
}

DIGESTS = {
    "uart/up": "36e8ade320d9b4672af78fb56f56b1fc59398964f9bc1491f38966ed101f3336",
    "sik/up": "dbad8deeb30a42f49ca01ad71621b642acbd2d192fe20409f3fe657b01b8f0d8",
    "wifi-edge-edge/up": "dc219ca5aec7e9df15e704e9341217a1e6be5983b5ed6584cac150495cb055e6",
    "wifi-fog-fog/up": "445971a6af0bb578305d36423ffd757195c5ffe5a2c6ef12b7714e83b0c82d55",
    "lte/up": "16b9b92129828ab1a6d090d2c03772fab8fa08c18959ca8bfaa8fb0a868a9f9f",
    "lte/down": "ef577205309f1dd612c76a963045f495c3617fe11a39012cd771d622381fe68d",
    "wired/up": "57c8c6ada6b56a8643e9a3ba5f95ee8a480796da2525dee5c429a139e9166191",
    "gamma-outages": "f54c7b78f98e13f97e13a4423c59fe661af0029f3282ca251bb33874498a0fe3",
    "ideal": "6364ba2ec7dc35cf02f2e05b3814e48bef28512b5f2d54c5ac4f7d344725c1ef",
}
"""sha256 of the (arrival s, drop) sequence and the channel's statistics, per link."""


def _params(name: str) -> LinkParams:
    if name in _CUSTOM:
        return _CUSTOM[name]
    preset, direction = name.split("/")
    up, down = LinksConfig.load().link(preset)
    return up if direction == "up" else down


def _digest(params: LinkParams, seed: int = 5) -> str:
    """3000 datagrams of random sizes in bursts, at distances across the range edge."""
    traffic = np.random.default_rng(seed)
    channel = LinkChannel(params, np.random.default_rng([seed, 1]))
    reach = params.range_m + 2.0 * params.range_width_m if math.isfinite(params.range_m) else 200.0
    now_s = 0.0
    out = []
    for _ in range(3000):
        now_s += float(traffic.exponential(0.002))
        size = int(traffic.integers(20, min(1400, params.max_datagram_bytes) + 1))
        distance_m = float(traffic.uniform(0.0, reach))
        arrival, drop = channel.submit(now_s, size, distance_m)
        out.append((arrival, None if drop is None else drop.value))
    stats = channel.stats
    out.append(
        (
            stats.submitted,
            stats.submitted_bytes,
            stats.delivered,
            stats.delivered_bytes,
            sorted(stats.dropped.items()),
            stats.airtime_s,
            stats.latencies_s.tolist(),
            channel.uptime_fraction(now_s),
        )
    )
    return hashlib.sha256(repr(out).encode()).hexdigest()


@pytest.mark.parametrize("name", list(DIGESTS))
def test_seeded_channel_gives_the_reference_drops_and_arrivals(name: str) -> None:
    """Arrival times, drop reasons and statistics are bit for bit those of the reference."""
    assert _digest(_params(name)) == DIGESTS[name]
