"""Procedural, seeded worlds: YAML schema, pure world descriptions and planner-map exports.

``load_world(path)`` validates a world YAML (errors name file, line and field), ``build(spec)``
turns it into a frozen :class:`World` from one seeded generator, and :mod:`worlds.maps` exports
occupancy grids, shapely polygons and networkx graphs. A leaf package: ``sitl`` builds worlds into
PyBullet, companion code may import the map data.
"""

from worlds.generate import build
from worlds.model import (
    Hotspot,
    LaunchArea,
    OilSpill,
    Person,
    Solid,
    SolidMotion,
    Surface,
    TaskPoint,
    Wind,
    World,
)
from worlds.schema import WorldSpec, WorldSpecError, load_world, parse_world

__all__ = [
    "Hotspot",
    "LaunchArea",
    "OilSpill",
    "Person",
    "Solid",
    "SolidMotion",
    "Surface",
    "TaskPoint",
    "Wind",
    "World",
    "WorldSpec",
    "WorldSpecError",
    "build",
    "load_world",
    "parse_world",
]
