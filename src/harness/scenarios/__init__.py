"""Shipped scenario files, one per world kind plus the demo's: ``scenario_path("offshore")``."""

from pathlib import Path

NAMES = (
    "offshore_demo",
    "offshore",
    "city",
    "indoor",
    "arena_aco",
    "workspace_mco",
    "taskmap",
    "swarm_coverage",
    "mco_urban",
    "caravan_kill",
    "aco_arena",
)


def scenario_path(name: str) -> Path:
    """Path of the shipped scenario ``name``; ``ValueError`` naming the ones there are otherwise."""
    if name not in NAMES:
        raise ValueError(f"no shipped scenario {name!r}; one of {list(NAMES)}")
    return Path(__file__).with_name(f"{name}.yaml")
