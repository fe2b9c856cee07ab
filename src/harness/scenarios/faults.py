"""``faults:``: vehicles that crash, land or lose their radio at a set or a drawn time.

Each entry picks its vehicles (one ``vehicle`` by number, or a ``fraction`` of the fleet drawn at
random) and a time (``at_s``, or uniform over ``between_s`` for each picked vehicle), and applies
one kind or several together (``kind: [crash, radio]`` is a vehicle lost with its radio):

* ``crash``: motors off (full fidelity: the autopilot's flight termination; the companion keeps
  running); ``land``: the vehicle lands where it is (the autopilot's Land mode);
* ``radio_tx`` / ``radio_rx`` / ``radio``: the vehicle's messaging node stops sending, receiving,
  or both (full fidelity: at the node's port).

Common random numbers: every random draw comes from a generator seeded by the run's seed and the
entry's position in the list only, so the same seed gives the same faults whatever the
companions do (seed 003 compares its algorithms on the same losses). ``resolve_faults`` turns the
entries into a time-ordered list of :class:`Fault`; a fault whose effect is already in force (a
vehicle lost twice, a radio already silent) is dropped there, so a report lists it once.
docs/scenarios.md ("Faults") describes the section.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

FaultKind = Literal["crash", "land", "radio_tx", "radio_rx", "radio"]
FAULT_KINDS: tuple[str, ...] = ("crash", "land", "radio_tx", "radio_rx", "radio")
EFFECTS: dict[str, frozenset[str]] = {
    "crash": frozenset({"lost"}),
    "land": frozenset({"lost"}),
    "radio_tx": frozenset({"tx"}),
    "radio_rx": frozenset({"rx"}),
    "radio": frozenset({"tx", "rx"}),
}
"""What each kind takes from a vehicle: a lost vehicle (crashed or landed) is lost once."""
FAULT_STREAM = 0xFA17
"""Mixed into each entry's generator seed, so fault draws never share a stream with others."""
Rounding = Literal["stochastic", "nearest", "floor", "ceil"]


class FaultSpec(BaseModel):
    """One entry of ``faults:``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kind: FaultKind | list[FaultKind]
    """What happens: ``crash``, ``land``, ``radio_tx``, ``radio_rx``, ``radio`` (both), or a
    list of them applied together."""
    vehicle: int | None = Field(None, ge=1)
    """The vehicle, by number from 1 (``vehicle3`` of the report is 3)."""
    fraction: float | None = Field(None, ge=0.0, le=1.0)
    """A fraction of the fleet, 0..1, picked at random (without repeats) from the run's seed."""
    rounding: Rounding = "stochastic"
    """How ``fraction`` x vehicles becomes a count: ``stochastic`` (floor, plus one with the
    fractional part's probability: the mean count is exactly fraction x vehicles), ``nearest``
    (half up), ``floor``, ``ceil``."""
    at_s: float | None = Field(None, ge=0.0)
    """When, simulated s."""
    between_s: tuple[float, float] | None = None
    """A window [from, to], simulated s: each picked vehicle's time is uniform in it."""

    @field_validator("kind")
    @classmethod
    def _kinds(cls, kind: str | list[str]) -> str | list[str]:
        if isinstance(kind, list):
            if not kind:
                raise ValueError("an empty list of kinds (give at least one)")
            if len(set(kind)) != len(kind):
                raise ValueError(f"a kind appears twice in {kind}")
        return kind

    @field_validator("between_s")
    @classmethod
    def _window(cls, window: tuple[float, float] | None) -> tuple[float, float] | None:
        if window is not None and not 0.0 <= window[0] <= window[1]:
            raise ValueError(f"[from, to] with 0 <= from <= to, got {list(window)}")
        return window

    @model_validator(mode="after")
    def _one_each(self) -> FaultSpec:
        if (self.vehicle is None) == (self.fraction is None):
            raise ValueError("give vehicle (a number from 1) or fraction (of the fleet), one")
        if (self.at_s is None) == (self.between_s is None):
            raise ValueError("give at_s (a time) or between_s (a window), one")
        return self

    @property
    def kinds(self) -> tuple[str, ...]:
        """The entry's kinds, in the file's order."""
        return tuple(self.kind) if isinstance(self.kind, list) else (self.kind,)

    def check_run(self, vehicles: int, duration_s: float) -> tuple[str, str] | None:
        """What is wrong with the entry for a fleet of ``vehicles`` and a run of ``duration_s``.

        (field, problem), or None when the entry fits.
        """
        if self.vehicle is not None and self.vehicle > vehicles:
            return "vehicle", f"vehicle {self.vehicle} does not exist (the fleet has {vehicles})"
        if self.at_s is not None and self.at_s > duration_s:
            return "at_s", f"{self.at_s:g} s is after the run's end (duration_s {duration_s:g})"
        if self.between_s is not None and self.between_s[1] > duration_s:
            return "between_s", (
                f"{list(self.between_s)} ends after the run's end (duration_s {duration_s:g})"
            )
        return None


@dataclass(frozen=True)
class Fault:
    """One fault of one vehicle at one time (an entry resolved)."""

    vehicle: int
    """0-based vehicle index."""
    kinds: tuple[str, ...]
    time_s: float
    """When it is due, simulated s."""
    entry: int
    """Its entry's position in ``faults:``."""

    @property
    def effects(self) -> frozenset[str]:
        """What it takes from the vehicle (``lost``, ``tx``, ``rx``)."""
        return frozenset().union(*(EFFECTS[k] for k in self.kinds))

    @property
    def silences(self) -> tuple[bool, bool]:
        """Whether it silences the vehicle's radio (sending, hearing)."""
        effects = self.effects
        return "tx" in effects, "rx" in effects

    def record(self, applied_s: float | None) -> dict[str, Any]:
        """The report's entry: which vehicle, what, when it was applied (simulated s).

        ``applied_s`` None: the run ended before the fault was due (``time_s`` null,
        ``applied`` false).
        """
        return {
            "vehicle": f"vehicle{self.vehicle + 1}",
            "kind": "+".join(self.kinds),
            "time_s": None if applied_s is None else round(float(applied_s), 6),
            "due_s": round(self.time_s, 6),
            "entry": self.entry,
            "applied": applied_s is not None,
        }


def fault_count(fraction: float, vehicles: int, rounding: str, u: float) -> int:
    """Vehicles a ``fraction`` of the fleet stands for (``u``: the draw of ``stochastic``)."""
    x = fraction * vehicles
    if rounding == "nearest":
        count = math.floor(x + 0.5)
    elif rounding == "floor":
        count = math.floor(x + 1e-9)
    elif rounding == "ceil":
        count = math.ceil(x - 1e-9)
    else:
        whole = math.floor(x + 1e-9)
        count = whole + int(u < x - whole)
    return max(0, min(vehicles, count))


def resolve_faults(entries: Sequence[FaultSpec], vehicles: int, seed: int) -> list[Fault]:
    """Every fault of the run, by time (then entry), with effects already in force dropped.

    Each entry draws from its own generator (the run's ``seed``, :data:`FAULT_STREAM` and its
    position): first the stochastic rounding's uniform, then the vehicles (a permutation of the
    fleet, the first ``count``), then one time per picked vehicle; the draws are made whether
    used or not, so changing one entry's values does not shift another's.
    """
    due: list[Fault] = []
    for k, entry in enumerate(entries):
        rng = np.random.default_rng([int(seed), FAULT_STREAM, k])
        u = float(rng.uniform())
        order = rng.permutation(vehicles)
        if entry.vehicle is not None:
            picked = [entry.vehicle - 1]
        else:
            assert entry.fraction is not None
            picked = sorted(int(i) for i in order[: fault_count(entry.fraction, vehicles,
                                                                 entry.rounding, u)])  # fmt: skip
        times = rng.uniform(0.0, 1.0, vehicles)  # one per vehicle index, used by the picked
        for i in picked:
            if entry.at_s is not None:
                t = float(entry.at_s)
            else:
                assert entry.between_s is not None
                lo, hi = entry.between_s
                t = lo + (hi - lo) * float(times[i])
            due.append(Fault(i, entry.kinds, t, k))
    due.sort(key=lambda f: (f.time_s, f.entry, f.vehicle))
    in_force: dict[int, set[str]] = {}
    out = []
    for fault in due:
        had = in_force.setdefault(fault.vehicle, set())
        kinds = tuple(k for k in fault.kinds if EFFECTS[k] - had)
        if not kinds:
            continue  # a lost vehicle is lost once; a silent radio goes silent once
        kept = Fault(fault.vehicle, kinds, fault.time_s, fault.entry)
        had |= kept.effects
        out.append(kept)
    return out
