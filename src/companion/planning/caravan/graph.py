"""The ICF lower tier: an 8-connected lattice over the task map and Dijkstra on it (Sec. 3.5).

Seed 003 gives the graph G = (V, E) with the tasks on vertices but not its construction (digest
gap 2). Here: the grid points of the map, ``spacing_m`` apart, centred on 0 (the convention of
``worlds.arenas.build_taskmap``: x from -sx/2 to sx/2, vertex index ``iy * nx + ix``), each joined
to its 8 neighbours by an edge of its Euclidean length. At constant speed the shortest path is
the shortest time (Sec. 3.5), which Eq. (26) turns into the bid.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra


class TaskGraph:
    """An 8-connected lattice over a ``size_m`` rectangle centred on 0, with cached Dijkstra.

    Args:
        size_m: (sx, sy) map size, m.
        spacing_m: distance between neighbouring grid points, m.
    """

    def __init__(self, size_m: tuple[float, float], spacing_m: float) -> None:
        sx, sy = (float(v) for v in size_m)
        if not (sx > 0 and sy > 0):
            raise ValueError(f"size_m: must be positive, got {size_m}")
        if not spacing_m > 0:
            raise ValueError(f"spacing_m: must be > 0, got {spacing_m}")
        self.spacing_m = float(spacing_m)
        self.gx = np.arange(-sx / 2.0, sx / 2.0 + 1e-9, self.spacing_m)
        self.gy = np.arange(-sy / 2.0, sy / 2.0 + 1e-9, self.spacing_m)
        nx, ny = self.gx.size, self.gy.size
        self.nx, self.ny = nx, ny
        ix, iy = np.meshgrid(np.arange(nx), np.arange(ny))
        ix, iy = ix.ravel(), iy.ravel()
        self.vertices_xy = np.column_stack((self.gx[ix], self.gy[iy]))
        """(V, 2) vertex positions, m; vertex ``iy * nx + ix``."""
        rows, cols, weights = [], [], []
        for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
            ok = (ix + dx < nx) & (iy + dy >= 0) & (iy + dy < ny)
            a = iy[ok] * nx + ix[ok]
            b = (iy[ok] + dy) * nx + ix[ok] + dx
            w = self.spacing_m * math.hypot(dx, dy)
            rows += [a, b]
            cols += [b, a]
            weights += [np.full(a.size, w), np.full(a.size, w)]
        v = nx * ny
        self.edges: csr_matrix = coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(v, v)
        ).tocsr()
        self._cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return self.nx * self.ny

    def vertices_of(self, xy: np.ndarray) -> np.ndarray:
        """Nearest vertex of each point of ``xy`` ((K, 2) m) -> (K,) int."""
        p = np.asarray(xy, dtype=float).reshape(-1, 2)
        ix = np.clip(np.rint((p[:, 0] - self.gx[0]) / self.spacing_m), 0, self.nx - 1)
        iy = np.clip(np.rint((p[:, 1] - self.gy[0]) / self.spacing_m), 0, self.ny - 1)
        return (iy * self.nx + ix).astype(int)

    def vertex_of(self, xy: np.ndarray | tuple[float, float]) -> int:
        """The vertex nearest to ``xy`` (m)."""
        return int(self.vertices_of(np.asarray(xy, dtype=float))[0])

    def _tree(self, source: int) -> tuple[np.ndarray, np.ndarray]:
        """Dijkstra from ``source``: (distances m, predecessors), cached per source vertex."""
        hit = self._cache.get(source)
        if hit is None:
            dist, pred = dijkstra(self.edges, indices=source, return_predecessors=True)
            hit = self._cache[source] = (dist, pred)
        return hit

    def path_lengths_m(self, from_xy: np.ndarray, targets_xy: np.ndarray) -> np.ndarray:
        """Length of the lattice route to each target, m (see ``travel_times_s``)."""
        here = np.asarray(from_xy, dtype=float).reshape(2)
        targets = np.asarray(targets_xy, dtype=float).reshape(-1, 2)
        source = self.vertex_of(here)
        dist, _ = self._tree(source)
        tv = self.vertices_of(targets)
        hop_in = float(np.hypot(*(self.vertices_xy[source] - here)))
        hop_out = np.hypot(*(targets - self.vertices_xy[tv]).T)
        return hop_in + dist[tv] + hop_out

    def travel_times_s(
        self, from_xy: np.ndarray, targets_xy: np.ndarray, speed_m_s: float
    ) -> np.ndarray:
        """Time to each target along the lattice at ``speed_m_s``, s (Sec. 3.5: the bid's t_v).

        The straight hop from ``from_xy`` to its nearest vertex, the shortest lattice path from
        there to the target's nearest vertex (Dijkstra), and the hop from that vertex to the
        target (0 for tasks, which sit on vertices).
        """
        if not speed_m_s > 0:
            raise ValueError(f"speed_m_s: must be > 0, got {speed_m_s}")
        return self.path_lengths_m(from_xy, targets_xy) / float(speed_m_s)

    def path_xy(self, from_xy: np.ndarray, target_xy: np.ndarray) -> np.ndarray:
        """(K, 2) lattice route from ``from_xy`` to ``target_xy``, m: corner points only.

        The points where the direction changes (the vertex nearest to the start first if the
        route turns there), ending exactly at ``target_xy``; ``from_xy`` itself is not listed.
        """
        here = np.asarray(from_xy, dtype=float).reshape(2)
        goal = np.asarray(target_xy, dtype=float).reshape(2)
        source = self.vertex_of(here)
        _, pred = self._tree(source)
        v = self.vertex_of(goal)
        chain = [v]
        while v != source:
            v = int(pred[v])
            chain.append(v)
        pts = np.vstack([here[None, :], self.vertices_xy[chain[::-1]], goal[None, :]])
        step = np.diff(pts, axis=0)
        keep = np.hypot(step[:, 0], step[:, 1]) > 1e-9
        pts = np.vstack([pts[:1], pts[1:][keep]])
        if len(pts) == 1:
            return goal[None, :].copy()
        d = np.diff(pts, axis=0)
        d /= np.hypot(d[:, 0], d[:, 1])[:, None]
        turn = np.abs(d[1:, 0] * d[:-1, 1] - d[1:, 1] * d[:-1, 0]) > 1e-9
        turn |= np.einsum("ij,ij->i", d[1:], d[:-1]) < 0
        corners = pts[1:-1][turn]
        return np.vstack([corners, goal[None, :]])
