"""The simulation clock: an integer count of physics steps, the only time the simulator knows."""

from __future__ import annotations


def rate_divisor(physics_hz: float, rate_hz: float, name: str) -> int:
    """Number of physics steps per period of a rate that must divide the physics rate.

    Raises:
        ValueError: if the rate is not positive or does not divide the physics rate.
    """
    if not rate_hz > 0.0:
        raise ValueError(f"{name} must be positive, got {rate_hz!r}")
    ratio = physics_hz / rate_hz
    divisor = round(ratio)
    if divisor < 1 or abs(ratio - divisor) > 1e-9 * ratio:
        raise ValueError(
            f"{name}={rate_hz:g} Hz does not divide physics_hz={physics_hz:g} Hz "
            f"(physics_hz / {name} = {ratio:g} must be a whole number >= 1)"
        )
    return divisor


class SimClock:
    """Simulation time as a whole number of physics steps (no floating-point drift)."""

    def __init__(self, physics_hz: float) -> None:
        if not physics_hz > 0.0:
            raise ValueError(f"physics_hz must be positive, got {physics_hz!r}")
        self.physics_hz = float(physics_hz)
        """Physics rate, Hz."""
        self.dt_s = 1.0 / self.physics_hz
        """Physics step, s."""
        self.tick = 0
        """Physics steps taken since the start."""

    @property
    def time_s(self) -> float:
        """Simulation time since the start, s."""
        return self.tick / self.physics_hz

    @property
    def time_usec(self) -> int:
        """Simulation time since the start, whole microseconds (MAVLink ``time_usec``)."""
        return round(self.tick * 1_000_000 / self.physics_hz)

    def advance(self) -> None:
        """Count one physics step."""
        self.tick += 1
