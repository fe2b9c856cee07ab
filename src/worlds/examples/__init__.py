"""Shipped example world files, one per kind: ``example_path("offshore")``."""

from pathlib import Path

KINDS = ("offshore", "city", "indoor", "arena_aco", "workspace_mco", "taskmap")
"""One example per world kind, in the file named after the kind."""
FIELDS = ("mco_rejoya", "mco_urban", "mco_naranjos")
"""Seed 004's three workspaces (``workspace_mco`` with explicit outlines; docs/seed004.md)."""


EXAMPLE_PREFIX = "example:"
"""``example:offshore`` names the shipped example of a kind wherever a world file is asked for."""


def world_path(name: str | Path) -> Path:
    """The world file ``name`` stands for: ``example:KIND`` is a shipped example, else a path."""
    text = str(name)
    if text.startswith(EXAMPLE_PREFIX):
        return example_path(text[len(EXAMPLE_PREFIX) :])
    return Path(name)


def example_path(kind: str) -> Path:
    """Path of the shipped example YAML for ``kind`` or a name of FIELDS (``ValueError`` else)."""
    if kind not in KINDS + FIELDS:
        raise ValueError(f"kind: no example {kind!r}; one of {list(KINDS + FIELDS)}")
    return Path(__file__).with_name(f"{kind}.yaml")
