"""Shipped example world files, one per kind: ``example_path("offshore")``."""

from pathlib import Path

KINDS = ("offshore", "city", "indoor", "arena_aco", "workspace_mco", "taskmap")


def example_path(kind: str) -> Path:
    """Path of the shipped example YAML for ``kind``; ``ValueError`` naming the kinds otherwise."""
    if kind not in KINDS:
        raise ValueError(f"kind: no example {kind!r}; one of {list(KINDS)}")
    return Path(__file__).with_name(f"{kind}.yaml")
