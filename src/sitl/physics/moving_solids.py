"""Moving solids of a ``worlds`` world: their PyBullet bodies follow ``Solid.center_at(t_s)``.

PyBullet has no batch call to move bodies, so the positions are computed for every mover at once
(numpy, the same reflecting-path formula as ``worlds.model.bounce``) and set one body at a time,
only for the solids that move and only at ``MOVING_SOLIDS_HZ`` of simulation time, never on
every physics step.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sitl.physics.bullet_import import pybullet as p
from worlds import Solid
from worlds.model import bounce

MOVING_SOLIDS_HZ = 10.0
"""Rate at which moving solids' bodies are moved, Hz of simulation time: at the few m/s of the
worlds' movers a body lags its true path by at most a few decimetres, well inside their sizes,
and moving a handful of bodies ten times a simulated second costs nothing next to the physics."""


class MovingSolids:
    """The moving subset of a world's solids and their body ids; ``update(t_s)`` moves them."""

    def __init__(self, client_id: int, solids: Sequence[Solid], body_ids: Sequence[int]) -> None:
        """Keep the solids with a ``motion`` (``body_ids[k]`` is the body of ``solids[k]``)."""
        if len(solids) != len(body_ids):
            raise ValueError(f"{len(solids)} solids but {len(body_ids)} body ids")
        movers = [(s, b) for s, b in zip(solids, body_ids, strict=True) if s.motion is not None]
        self._client_id = client_id
        self.body_ids: list[int] = [b for _, b in movers]
        """Body ids of the moving solids, in the order of the world's solids."""
        motions = [s.motion for s, _ in movers if s.motion is not None]
        m = len(movers)
        starts = [s.center_enu_m[:2] for s, _ in movers]
        self._start_xy = np.array(starts, dtype=float).reshape(m, 2)
        self._z0 = np.array([s.center_enu_m[2] for s, _ in movers], dtype=float)
        self._velocity_xy = np.array([mo.velocity_xy_m_s for mo in motions], dtype=float).reshape(
            m, 2
        )
        bounds = np.array([mo.bounds_xy_m for mo in motions], dtype=float).reshape(m, 4)
        self._low, self._high = bounds[:, :2], bounds[:, 2:]
        self._amplitude = np.array([mo.vertical_amplitude_m for mo in motions], dtype=float)
        self._omega = np.array([2.0 * np.pi / mo.vertical_period_s for mo in motions], dtype=float)
        self._phase = np.array([mo.phase_rad for mo in motions], dtype=float)
        self._orientation = [
            p.getQuaternionFromEuler([0.0, 0.0, np.radians(s.yaw_deg if s.shape == "box" else 0.0)])
            for s, _ in movers
        ]

    def __len__(self) -> int:
        """Number of moving solids."""
        return len(self.body_ids)

    def centers_at(self, t_s: float) -> np.ndarray:
        """Centres of the moving solids at ``t_s``, (M, 3) ENU, m."""
        xy = bounce(self._start_xy, self._velocity_xy, self._low, self._high, t_s)
        z = self._z0 + self._amplitude * np.sin(self._omega * t_s + self._phase)
        return np.column_stack([xy, z])

    def update(self, t_s: float) -> None:
        """Move every moving solid's body to where it is at ``t_s``."""
        if not self.body_ids:
            return
        for body, center, orientation in zip(
            self.body_ids, self.centers_at(t_s).tolist(), self._orientation, strict=True
        ):
            p.resetBasePositionAndOrientation(
                body, center, orientation, physicsClientId=self._client_id
            )
