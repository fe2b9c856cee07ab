"""Obstacles in the PyBullet scene: boxes (walls, shelves, buildings) and vertical cylinders.

Obstacles are what the rangefinders' rays hit and the cameras see besides the ground; they have a
collision shape (rays, contacts) and a visual shape of the same size (rendering). Positions are in
the world's ENU frame with z up, the ground plane at z = 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from sitl.physics.bullet_import import pybullet as p
from worlds import Solid


@dataclass(frozen=True)
class BoxObstacle:
    """A static box, e.g. a wall 0.2 m thick: ``BoxObstacle((0, 2.1, 1.5), (10, 0.2, 3))``."""

    center_enu_m: tuple[float, float, float]
    """Centre of the box, ENU, m."""
    size_m: tuple[float, float, float]
    """Full extents along the box's own x, y, z axes (before yaw), m; each > 0."""
    yaw_deg: float = 0.0
    """Rotation about the vertical, counter-clockwise from ENU x (east), degrees."""
    rgba: tuple[float, float, float, float] = (0.55, 0.55, 0.58, 1.0)
    """Colour the cameras see, each channel in [0, 1]."""

    def __post_init__(self) -> None:
        for name in ("center_enu_m", "size_m", "rgba"):
            value = tuple(float(v) for v in getattr(self, name))
            expected = 4 if name == "rgba" else 3
            if len(value) != expected or not all(math.isfinite(v) for v in value):
                raise ValueError(f"BoxObstacle.{name} needs {expected} finite numbers, got {value}")
            object.__setattr__(self, name, value)
        if not all(s > 0.0 for s in self.size_m):
            raise ValueError(f"BoxObstacle.size_m must be positive, got {self.size_m}")
        if not all(0.0 <= c <= 1.0 for c in self.rgba):
            raise ValueError(f"BoxObstacle.rgba channels must be in [0, 1], got {self.rgba}")
        if not math.isfinite(self.yaw_deg):
            raise ValueError(f"BoxObstacle.yaw_deg must be finite, got {self.yaw_deg}")


def add_boxes(client_id: int, boxes: Sequence[BoxObstacle]) -> list[int]:
    """Create each box as a fixed (mass 0) body in PyBullet client ``client_id``; their body ids."""
    ids = []
    for box in boxes:
        half = [s / 2.0 for s in box.size_m]
        collision = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client_id)
        visual = p.createVisualShape(
            p.GEOM_BOX, halfExtents=half, rgbaColor=list(box.rgba), physicsClientId=client_id
        )
        orientation = p.getQuaternionFromEuler([0.0, 0.0, math.radians(box.yaw_deg)])
        ids.append(
            p.createMultiBody(
                0.0,
                collision,
                visual,
                basePosition=list(box.center_enu_m),
                baseOrientation=orientation,
                physicsClientId=client_id,
            )
        )
    return ids


@dataclass(frozen=True)
class CylinderObstacle:
    """A static vertical cylinder, e.g. a platform leg 1 m across and 20 m high."""

    center_enu_m: tuple[float, float, float]
    """Centre of the cylinder (half-way up its axis), ENU, m."""
    diameter_m: float
    """Diameter, m; > 0."""
    height_m: float
    """Height along the vertical axis, m; > 0."""
    rgba: tuple[float, float, float, float] = (0.55, 0.55, 0.58, 1.0)
    """Colour the cameras see, each channel in [0, 1]."""

    def __post_init__(self) -> None:
        for name in ("center_enu_m", "rgba"):
            value = tuple(float(v) for v in getattr(self, name))
            expected = 4 if name == "rgba" else 3
            if len(value) != expected or not all(math.isfinite(v) for v in value):
                raise ValueError(
                    f"CylinderObstacle.{name} needs {expected} finite numbers, got {value}"
                )
            object.__setattr__(self, name, value)
        for name in ("diameter_m", "height_m"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"CylinderObstacle.{name} must be positive, got {value}")
            object.__setattr__(self, name, value)
        if not all(0.0 <= c <= 1.0 for c in self.rgba):
            raise ValueError(f"CylinderObstacle.rgba channels must be in [0, 1], got {self.rgba}")


def add_cylinders(client_id: int, cylinders: Sequence[CylinderObstacle]) -> list[int]:
    """Create each cylinder as a fixed (mass 0) body, axis vertical; their body ids."""
    ids = []
    for cyl in cylinders:
        radius = cyl.diameter_m / 2.0
        collision = p.createCollisionShape(
            p.GEOM_CYLINDER, radius=radius, height=cyl.height_m, physicsClientId=client_id
        )
        visual = p.createVisualShape(
            p.GEOM_CYLINDER,
            radius=radius,
            length=cyl.height_m,
            rgbaColor=list(cyl.rgba),
            physicsClientId=client_id,
        )
        ids.append(
            p.createMultiBody(
                0.0,
                collision,
                visual,
                basePosition=list(cyl.center_enu_m),
                physicsClientId=client_id,
            )
        )
    return ids


def add_solids(client_id: int, solids: Sequence[Solid]) -> list[int]:
    """Create a ``worlds`` world's solids (boxes, vertical cylinders) at their t = 0 places.

    Each becomes a fixed body; moving ones are moved later with
    ``resetBasePositionAndOrientation`` (see ``sitl.physics.moving_solids``). Their body ids,
    in the order of ``solids``.
    """
    ids = []
    for solid in solids:
        if solid.shape == "cylinder":
            diameter, height = solid.size_m[0], solid.size_m[2]
            shape = CylinderObstacle(solid.center_enu_m, diameter, height, solid.rgba)
            ids.extend(add_cylinders(client_id, [shape]))
        else:
            box = BoxObstacle(solid.center_enu_m, solid.size_m, solid.yaw_deg, solid.rgba)
            ids.extend(add_boxes(client_id, [box]))
    return ids
