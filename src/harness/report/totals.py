"""A run's report totals and bounds, at every fidelity.

Fleet totals of the companions' results, ``checks.metrics`` bounds, dotted lookups, and the
versions a run's outcome depends on.

Light on purpose (no simulator import): the swarm-scale engine and sweep workers use it too.
"""

from __future__ import annotations

import contextlib
import math
import platform
from importlib import metadata
from typing import Any


def versions() -> dict[str, str]:
    """Versions of what a run's outcome depends on."""
    out = {"python": platform.python_version()}
    for dist in ("swarmsitl", "numpy", "pybullet", "pymavlink", "mavsdk-grpc", "mavsdk"):
        with contextlib.suppress(metadata.PackageNotFoundError):
            out[dist] = metadata.version(dist)
    return out


def number_of(entry: Any) -> float:
    """A report quantity's number (``{"value": v, "unit": u}``, or a bare number) as a float.

    NaN for what is not a number: a missing entry, None (a non-finite value in JSON), a bool, a
    text.
    """
    if isinstance(entry, dict):
        entry = entry.get("value")
    if isinstance(entry, int | float) and not isinstance(entry, bool):
        return float(entry)
    return math.nan


FRACTION_UNITS = ("1", "fraction", "ratio", "%")
"""Units of companion results that are shares, which the fleet averages instead of adding."""


def fleet_totals(report: dict[str, Any]) -> dict[str, Any]:
    """Each companion result over the vehicles that reported it.

    Numbers: ``sum`` and ``mean``; ``value`` is the mean for shares (unit ``1``, ``fraction``,
    ``%``) and the sum for everything else (counts, metres, joules). Lists (e.g. the names of the
    targets a vehicle found): ``items``, their union, and ``value``, how many distinct items,
    which is what a fleet found when several vehicles found the same thing.
    """
    values: dict[str, list[float]] = {}
    lists: dict[str, set] = {}
    counts: dict[str, int] = {}
    units: dict[str, Any] = {}
    for metrics in report.get("vehicles", {}).values():
        for name, q in (metrics.get("companion") or {}).items():
            value = q.get("value") if isinstance(q, dict) else None
            if isinstance(value, list):
                lists.setdefault(name, set()).update(map(str, value))
                counts[name] = counts.get(name, 0) + 1
                continue
            if isinstance(value, bool) or not isinstance(value, int | float):
                continue
            values.setdefault(name, []).append(value)
            units.setdefault(name, q.get("unit"))
    totals: dict[str, Any] = {
        name: {
            "value": len(items),
            "unit": "distinct",
            "items": sorted(items),
            "vehicles": counts[name],
        }
        for name, items in lists.items()
    }
    for name, vs in values.items():
        total, mean = sum(vs), sum(vs) / len(vs)
        totals[name] = {
            "value": mean if units[name] in FRACTION_UNITS else total,
            "unit": units[name],
            "sum": total,
            "mean": mean,
            "vehicles": len(vs),
        }
    return totals


def lookup(report: dict[str, Any], dotted: str) -> Any:
    """``report["a"]["b"]`` for ``a.b``; a ``{"value": v}`` leaf gives v; KeyError if absent."""
    node: Any = report
    for part in dotted.split("."):
        node = node[part]
    if isinstance(node, dict) and "value" in node:
        node = node["value"]
    return node


def metric_checks(
    report: dict[str, Any], bounds: dict[str, tuple[float | None, float | None]]
) -> dict[str, dict[str, Any]]:
    """The scenario's ``checks.metrics`` bounds evaluated on the report."""
    out = {}
    for name, (low, high) in bounds.items():
        try:
            value = float(lookup(report, name))
        except (KeyError, TypeError, ValueError):
            out[f"metric {name}"] = {
                "ok": False,
                "value": None,
                "message": f"{name}: not in report",
            }
            continue
        ok = (low is None or value >= low) and (high is None or value <= high)
        out[f"metric {name}"] = {
            "ok": ok,
            "value": value,
            "message": f"{name} = {value:g} (bounds [{low}, {high}])",
        }
    return out
