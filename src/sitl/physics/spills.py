"""Oil spills and people of a ``worlds`` world as PyBullet bodies.

**Spills** are flat, visual-only patches (a GEOM_MESH triangulated from the outline, no collision
shape: rangefinder rays and vehicles pass through them, cameras draw them) lying
``SPILL_HEIGHT_M`` above the sea. Until its ``appear_s`` a spill is parked ``HIDDEN_DEPTH_M``
under the surface, beyond every camera's far clip, so no camera draws it; ``OilSpills.update``
raises the spills that fell due, checked at the 10 Hz of the moving solids (one numpy compare;
nothing per physics step).

**People** are upright cylinders with a collision shape (rangefinders and vehicles hit them),
standing on ``Person.position_enu_m`` (their feet), ``PERSON_DIAMETER_M`` across.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from sitl.physics.bullet_import import pybullet as p
from sitl.physics.obstacles import CylinderObstacle, add_cylinders
from worlds import OilSpill, Person

SPILL_HEIGHT_M = 0.005
"""Height of a visible spill above the sea surface (z = 0), m: a few mm, invisible as height from
the air; the cameras draw what ties with the ground's depth (``camera_ground``), so the patch shows
even where the depth buffer cannot resolve the gap (7 cm at 250 m)."""
HIDDEN_DEPTH_M = 1.0e4
"""How far under the surface a spill waits for its ``appear_s``, m (beyond any far clip)."""
PERSON_DIAMETER_M = 0.5
"""Diameter of the cylinder standing for a person, m (shoulder width)."""


def spill_mesh(spill: OilSpill) -> tuple[np.ndarray, np.ndarray, tuple[float, float]]:
    """Triangulated outline: vertices (V, 3) relative to the anchor, indices (3 T,), the anchor.

    The outline's constrained Delaunay triangulation (shapely): triangles cover the polygon,
    concave bays included, and nothing outside it. The anchor is the outline's first vertex.
    """
    polygon = spill.polygon
    if not polygon.is_valid:
        polygon = polygon.buffer(0)
    triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(polygon))
    coords = shapely.get_coordinates(triangles).reshape(len(triangles), 4, 2)[:, :3]
    anchor = (float(spill.outline_xy_m[0][0]), float(spill.outline_xy_m[0][1]))
    xy = coords.reshape(-1, 2) - anchor
    # Counter-clockwise seen from above: the face's normal points up, towards the cameras.
    a, b, c = coords[:, 0], coords[:, 1], coords[:, 2]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    order = np.arange(3 * len(triangles)).reshape(-1, 3)
    order[cross < 0] = order[cross < 0][:, ::-1]
    vertices = np.column_stack([xy, np.zeros(len(xy))])
    return vertices, order.reshape(-1), anchor


class OilSpills:
    """The spills' bodies; ``update(t_s)`` raises the ones whose ``appear_s`` has come."""

    def __init__(self, client_id: int, spills: Sequence[OilSpill]) -> None:
        """Create one visual-only body per spill, hidden or shown as at t = 0."""
        self._client_id = client_id
        self.spills = tuple(spills)
        self.body_ids: list[int] = []
        """PyBullet body id of each spill, in order."""
        self.visual_corners_local: dict[int, np.ndarray] = {}
        """Each body's visual bounding-box corners (8, 3) in its frame (the cameras' culling)."""
        self._anchors = np.zeros((len(self.spills), 2))
        for k, spill in enumerate(self.spills):
            vertices, indices, anchor = spill_mesh(spill)
            visual = p.createVisualShape(
                p.GEOM_MESH,
                vertices=vertices.tolist(),
                indices=indices.tolist(),
                rgbaColor=list(spill.rgba),
                physicsClientId=client_id,
            )
            body = p.createMultiBody(
                0.0,
                -1,
                visual,
                basePosition=[anchor[0], anchor[1], -HIDDEN_DEPTH_M],
                # A rigid body, not a multibody: PyBullet's step then skips it (about 0.7 us
                # per spill and step as a fixed multibody, nothing measurable this way).
                useMaximalCoordinates=True,
                physicsClientId=client_id,
            )
            self.body_ids.append(body)
            self._anchors[k] = anchor
            low, high = vertices.min(axis=0), vertices.max(axis=0)
            corners = np.array(
                [[(low, high)[i & 1][0], (low, high)[i >> 1 & 1][1], 0.0] for i in range(8)]
            )
            self.visual_corners_local[body] = corners
        self._appear_s = np.array([s.appear_s for s in self.spills], dtype=float)
        self.shown = np.zeros(len(self.spills), dtype=bool)
        """Whether each spill is up on the surface."""
        self.update(0.0)

    def __len__(self) -> int:
        """Number of spills."""
        return len(self.body_ids)

    @property
    def all_shown(self) -> bool:
        """Every spill is up (nothing left to do)."""
        return bool(self.shown.all())

    def update(self, t_s: float) -> None:
        """Raise the spills whose ``appear_s`` <= t_s to ``SPILL_HEIGHT_M`` (once each)."""
        due = np.flatnonzero(~self.shown & (self._appear_s <= t_s))
        for k in due.tolist():
            x, y = self._anchors[k]
            p.resetBasePositionAndOrientation(
                self.body_ids[k],
                [float(x), float(y), SPILL_HEIGHT_M],
                [0.0, 0.0, 0.0, 1.0],
                physicsClientId=self._client_id,
            )
        self.shown[due] = True


def add_people(client_id: int, people: Sequence[Person]) -> list[int]:
    """Each person as a fixed upright cylinder standing on its position; their body ids."""
    shapes = [
        CylinderObstacle(
            (
                person.position_enu_m[0],
                person.position_enu_m[1],
                person.position_enu_m[2] + person.height_m / 2.0,
            ),
            PERSON_DIAMETER_M,
            person.height_m,
            person.rgba,
        )
        for person in people
    ]
    return add_cylinders(client_id, shapes)
