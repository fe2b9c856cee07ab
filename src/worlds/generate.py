"""``build(spec)``: a validated world spec to a frozen :class:`~worlds.model.World`.

Every random draw of a world comes from ONE ``numpy.random.default_rng(spec.seed)``, in a fixed
order documented per kind, so the same spec gives the same world and another seed another world.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from worlds.arenas import build_arena_aco, build_taskmap, build_workspace_mco
from worlds.city import build_city
from worlds.indoor import build_indoor
from worlds.model import World
from worlds.offshore import build_offshore
from worlds.schema import WorldSpec

_BUILDERS: dict[str, Callable] = {
    "offshore": build_offshore,
    "city": build_city,
    "indoor": build_indoor,
    "arena_aco": build_arena_aco,
    "workspace_mco": build_workspace_mco,
    "taskmap": build_taskmap,
}


def build(spec: WorldSpec) -> World:
    """Generate the world ``spec`` describes; ``ValueError`` naming the field if it cannot fit."""
    return _BUILDERS[spec.kind](spec, np.random.default_rng(spec.seed))
