"""A world's solids as arrays: where they are at time t and how far a point is from each.

:class:`SolidSet` holds K boxes (with yaw) and vertical cylinders, static and moving, as (K, ...)
arrays, so that a fleet's distance to what is near costs a few numpy calls: ``centers_at(t)``
places the moving ones with the same motion law as :meth:`worlds.model.Solid.center_at` (both
call :func:`worlds.model.motion_centers`), a KD-tree over the centres at t picks the candidate
pairs within a search radius (``near``), and ``closest_points`` gives, for each pair, the point of
the solid's surface (or interior) nearest to the query point, in 3-D, heights included: a point
above a solid's top is clear of it by its height above the top.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial import cKDTree

from worlds.model import Solid, motion_centers


class SolidSet:
    """K solids as arrays (see the module docstring)."""

    def __init__(self, solids: Sequence[Solid]) -> None:
        self.solids = tuple(solids)
        self.names = [s.name for s in self.solids]
        k = len(self.solids)
        self.center0 = np.array([s.center_enu_m for s in self.solids], dtype=float).reshape(k, 3)
        """(K, 3) centres at t = 0, m."""
        self.half = np.array([s.size_m for s in self.solids], dtype=float).reshape(k, 3) / 2.0
        """(K, 3) half extents along the solid's own x, y and z, m (a cylinder: r, r, h/2)."""
        self.cylinder = np.array([s.shape == "cylinder" for s in self.solids], dtype=bool)
        yaw = np.radians([0.0 if s.shape == "cylinder" else s.yaw_deg for s in self.solids])
        self.cos_yaw, self.sin_yaw = np.cos(yaw), np.sin(yaw)
        self.moving = np.array([s.motion is not None for s in self.solids], dtype=bool)
        self._movers = [s for s in self.solids if s.motion is not None]
        self._mover_rows = np.flatnonzero(self.moving)
        self.reach_m = np.where(
            self.cylinder, self.half[:, 0], np.hypot(self.half[:, 0], self.half[:, 1])
        )
        """(K,) horizontal radius of the circle around each centre containing the footprint, m."""
        self.max_reach_m = float(np.hypot(self.reach_m, self.half[:, 2]).max()) if k else 0.0
        """Largest distance from a centre to a point of its solid (3-D), m."""
        self._cache: tuple[float, np.ndarray, cKDTree | None] | None = None

    def __len__(self) -> int:
        return len(self.solids)

    def centers_at(self, t_s: float) -> np.ndarray:
        """(K, 3) centres at simulated time ``t_s``, m."""
        out = self.center0.copy()
        if self._movers:
            out[self._mover_rows] = motion_centers(self._movers, t_s)
        return out

    def velocities_at(self, t_s: float, dt_s: float = 1e-3) -> np.ndarray:
        """(K, 3) velocities at ``t_s``, m/s (zeros for static ones; a central difference)."""
        out = np.zeros((len(self), 3))
        if self._movers:
            lo = motion_centers(self._movers, t_s - dt_s)
            hi = motion_centers(self._movers, t_s + dt_s)
            out[self._mover_rows] = (hi - lo) / (2.0 * dt_s)
        return out

    def _state(self, t_s: float) -> tuple[np.ndarray, cKDTree | None]:
        if self._cache is None or self._cache[0] != t_s:
            centers = self.centers_at(t_s)
            tree = cKDTree(centers) if len(self) else None
            self._cache = (t_s, centers, tree)
        return self._cache[1], self._cache[2]

    def near(
        self, points: np.ndarray, radius_m: float | np.ndarray, t_s: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pairs (point, solid) whose distance is at most ``radius_m``, at ``t_s``.

        Args:
            points: (P, 3) query points, ENU m.
            radius_m: search radius, one or (P,) (e.g. the sensing range plus the body's radius).
            t_s: simulated time, s.

        Returns:
            ``(p, k, closest)``: (M,) point indices, (M,) solid indices, and (M, 3) the closest
            point of solid k to point p; only pairs with ``|closest - point| <= radius``.
        """
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        rad = np.broadcast_to(np.asarray(radius_m, dtype=float), (len(pts),))
        empty = np.zeros(0, dtype=int)
        if not len(self) or not len(pts):
            return empty, empty, np.zeros((0, 3))
        centers, tree = self._state(t_s)
        assert tree is not None
        found = tree.query_ball_point(pts, rad + self.max_reach_m)
        counts = np.fromiter((len(f) for f in found), dtype=int, count=len(pts))
        if not counts.any():
            return empty, empty, np.zeros((0, 3))
        p = np.repeat(np.arange(len(pts)), counts)
        k = np.fromiter((j for f in found for j in f), dtype=int, count=int(counts.sum()))
        closest = self.closest_points(pts[p], k, centers[k])
        keep = np.linalg.norm(closest - pts[p], axis=1) <= rad[p]
        return p[keep], k[keep], closest[keep]

    def closest_points(self, points: np.ndarray, k: np.ndarray, centers: np.ndarray) -> np.ndarray:
        """(M, 3) point of solid ``k[m]`` (centred at ``centers[m]``) nearest to ``points[m]``.

        The point itself when it lies inside the solid.
        """
        d = points - centers
        h = self.half[k]
        # box: into its frame (undo the yaw), clamp to the half extents, back
        c, s = self.cos_yaw[k], self.sin_yaw[k]
        lx = c * d[:, 0] + s * d[:, 1]
        ly = -s * d[:, 0] + c * d[:, 1]
        bx = np.clip(lx, -h[:, 0], h[:, 0])
        by = np.clip(ly, -h[:, 1], h[:, 1])
        box_xy = np.column_stack((c * bx - s * by, s * bx + c * by))
        # cylinder: the horizontal offset shortened to the radius
        rho = np.hypot(d[:, 0], d[:, 1])
        scale = np.minimum(1.0, h[:, 0] / np.maximum(rho, 1e-12))[:, None]
        cyl_xy = d[:, :2] * scale
        xy = np.where(self.cylinder[k][:, None], cyl_xy, box_xy)
        z = np.clip(d[:, 2], -h[:, 2], h[:, 2])
        return centers + np.column_stack((xy, z))


def solid_distance(solid: Solid, point: Sequence[float], t_s: float = 0.0) -> float:
    """Distance from ``point`` to ``solid`` at ``t_s``, m (0 inside): a one-off convenience."""
    ss = SolidSet([solid])
    c = ss.centers_at(t_s)
    q = np.asarray(point, dtype=float).reshape(1, 3)
    return math.dist(ss.closest_points(q, np.zeros(1, dtype=int), c)[0], q[0])
