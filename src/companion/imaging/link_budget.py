"""What sending one byte over a link costs: time (the link's bandwidth) and energy (J per byte).

The companion cannot import the simulator's link models (``sitl.links``) nor its energy ledger
(``sitl.power``): it is told a link's numbers, by default the same figures those models use
(docs/links.md presets, seed 000 Table I radio powers), so that the T_compress policy and the
simulated links agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class LinkBudget:
    """Bandwidth and transmit power of the link images leave on."""

    rate_bytes_s: float
    """Goodput the link offers, bytes/s (a link model's ``rate_bps / 8``, or a measurement)."""
    tx_power_w: float
    """Power of the radio while it transmits, W (seed 000 Table I)."""
    name: str = "link"
    """For records and messages."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_bytes_s) and self.rate_bytes_s > 0):
            raise ValueError(f"rate_bytes_s: must be a finite number > 0, got {self.rate_bytes_s}")
        if not (math.isfinite(self.tx_power_w) and self.tx_power_w >= 0):
            raise ValueError(f"tx_power_w: must be a finite number >= 0, got {self.tx_power_w}")

    @property
    def j_per_byte(self) -> float:
        """Radio energy per byte sent, J/B: airtime per byte (1 / rate) times the transmit power.

        This is how the energy ledger (docs/energy.md) charges a radio: power x airtime.
        """
        return self.tx_power_w / self.rate_bytes_s

    def airtime_s(self, size_bytes: float) -> float:
        """Time on the medium of ``size_bytes``, s."""
        return size_bytes / self.rate_bytes_s


WIFI_EDGE_FOG = LinkBudget(520e6 / 8, 1.0, "wifi")
"""The ``wifi-edge-fog`` preset (520 Mbps goodput: 802.11ac 866.7 Mbps x 0.6 MAC efficiency, seed
000 Table II) and the 1 W radio of Table I: 1.5e-8 J/B."""
LTE_UPLINK = LinkBudget(50e6 / 8, 100.0, "lte")
"""The ``lte`` preset's uplink (50 Mbps, seed 000 Table II) and the 100 W "mobile comm. modules +
antenna" of Table I while transmitting: 1.6e-5 J/B (a thousand times WiFi's)."""
