"""Shipped example world files, one per kind: ``example_path("offshore")``."""

from pathlib import Path

KINDS = ("offshore", "city", "indoor", "arena_aco", "workspace_mco", "taskmap")


EXAMPLE_PREFIX = "example:"
"""``example:offshore`` names the shipped example of a kind wherever a world file is asked for."""


def world_path(name: str | Path) -> Path:
    """The world file ``name`` stands for: ``example:KIND`` is a shipped example, else a path."""
    text = str(name)
    if text.startswith(EXAMPLE_PREFIX):
        return example_path(text[len(EXAMPLE_PREFIX) :])
    return Path(name)


def example_path(kind: str) -> Path:
    """Path of the shipped example YAML for ``kind``; ``ValueError`` naming the kinds otherwise."""
    if kind not in KINDS:
        raise ValueError(f"kind: no example {kind!r}; one of {list(KINDS)}")
    return Path(__file__).with_name(f"{kind}.yaml")
