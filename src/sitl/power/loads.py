"""Electrical loads besides the rotors: avionics and payload, per vehicle.

Presets (``LOAD_PRESETS``), W:

- ``avionics`` (the default): flight controller 1.5 W (a Pixhawk-class board draws ~0.3 A at
  5 V), GNSS receiver and compass 0.5 W, telemetry/RC radio 1 W (seed 000, Table I, "Radios");
- ``seed000_companion``: avionics + the embedded computer of seed 000, Table I (27 W, a
  Raspberry Pi 5 companion) + its radio (1 W);
- ``seed000_fog``: seed000_companion + the mobile communication module and antenna of Table I
  (100 W), as carried by a fog-layer vehicle.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

AVIONICS_W: dict[str, float] = {"flight_controller": 1.5, "gnss_compass": 0.5, "radio": 1.0}
"""The default load: autopilot, GNSS and its telemetry radio, W."""

LOAD_PRESETS: dict[str, dict[str, float]] = {
    "avionics": AVIONICS_W,
    "seed000_companion": {**AVIONICS_W, "embedded_computer": 27.0, "companion_radio": 1.0},
    "seed000_fog": {
        **AVIONICS_W,
        "embedded_computer": 27.0,
        "companion_radio": 1.0,
        "mobile_comm_module": 100.0,
    },
}
"""Named load sets, W (seed 000 = Ramos et al. 2025, ARCog-NET, Table I)."""


@dataclass(frozen=True)
class PayloadLoads:
    """Constant electrical loads of one vehicle (hashable, like the rest of WorldConfig)."""

    loads_w: tuple[tuple[str, float], ...] = tuple(AVIONICS_W.items())
    """(load name, power in W) pairs."""

    def __post_init__(self) -> None:
        for name, watts in self.loads_w:
            if not watts >= 0.0:
                raise ValueError(f"load {name!r} must be >= 0 W, got {watts!r}")

    @property
    def total_w(self) -> float:
        """Sum of the loads, W."""
        return float(sum(w for _, w in self.loads_w))

    @classmethod
    def of(cls, loads_w: Mapping[str, float]) -> PayloadLoads:
        """Loads from a name -> W mapping."""
        return cls(tuple((str(k), float(v)) for k, v in loads_w.items()))

    @classmethod
    def preset(cls, name: str) -> PayloadLoads:
        """A named preset of ``LOAD_PRESETS``."""
        try:
            return cls.of(LOAD_PRESETS[name])
        except KeyError:
            raise ValueError(
                f"unknown load preset {name!r}; available: {', '.join(sorted(LOAD_PRESETS))}"
            ) from None
