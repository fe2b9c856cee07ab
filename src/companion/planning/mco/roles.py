"""Role allocation of the MCO Plan: Master, Coordinators, Operators per partition level.

Seed 004, Sec. 4.2.3 and Fig. 11: in each partition level the Master takes the sub-area closest to
the ground station (the level's takeoff location p0), the Coordinators the four sub-areas closest
to the Master's, the Operators the rest (the larger, peripheral ones). Table 2 (the scores each
role asks for) did not survive the text conversion: :data:`ROLE_SCORES` reads the prose as high /
middle / low = 3 / 1.5 / 0 on Eq. (2)'s 0..3 scale. The flight time a role asks for is not the
role's: it is what the sub-area's tour needs (:class:`companion.planning.mco.auction.Task`).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np


class Role(StrEnum):
    """A vehicle's role in the hierarchical society of Fig. 11, seed 004."""

    MASTER = "master"
    COORDINATOR = "coordinator"
    OPERATOR = "operator"


@dataclass(frozen=True)
class RoleScores:
    """What a role asks of a vehicle, on Eq. (2)'s scale (0: least, 3: most resources)."""

    decision: float
    """Decision capacity (autopilot type, onboard computer), score 0..3."""
    communication: float
    """Communication skill (telemetry module, data-flow support), score 0..3."""


ROLE_SCORES: dict[Role, RoleScores] = {
    Role.MASTER: RoleScores(decision=3.0, communication=3.0),
    Role.COORDINATOR: RoleScores(decision=1.5, communication=3.0),
    Role.OPERATOR: RoleScores(decision=0.0, communication=0.0),
}
"""Table 2 of seed 004 is missing: its words on Eq. (2)'s 0..3 scale, high = 3, middle = 1.5 (the
scale's middle), low = 0 (Sec. 4.2.3's prose). Eq. (2) scores a fleet's least capable vehicle 0,
so "low" must be 0 for an Operator task to be open to it; every MAV has basic communication (P3).
(The digest's suggestion, 3 / 2 / 1, closes Operator tasks to the least capable class.)"""


def assign_roles(
    sites_xy_m: np.ndarray,
    takeoff_xy_m: np.ndarray,
    coordinators: int = 4,
    level: np.ndarray | None = None,
) -> list[Role]:
    """The role of each sub-area (Sec. 4.2.3, Fig. 11, seed 004).

    Args:
        sites_xy_m: ``(n, 2)`` each sub-area's site (its Voronoi centroid), m.
        takeoff_xy_m: ``(2,)`` the takeoff location p0, or ``(v, 2)`` one per partition level
            (Phase IV), m.
        coordinators: Coordinators per level (fewer when the level has fewer sub-areas).
        level: ``(n,)`` each sub-area's partition level, an index into ``takeoff_xy_m``'s rows;
            ``None``: the level of the nearest takeoff location.

    Per level: the Master is the sub-area whose site is nearest that level's p0; the Coordinators
    are the ``coordinators`` sub-areas of the level whose sites are nearest the Master's site;
    the others are Operators. Equal distances go to the lower sub-area index.
    """
    sites = np.asarray(sites_xy_m, dtype=float)
    takeoffs = np.atleast_2d(np.asarray(takeoff_xy_m, dtype=float))
    if sites.ndim != 2 or sites.shape[1] != 2:
        raise ValueError(f"sites_xy_m must have shape (n, 2), got {sites.shape}")
    if takeoffs.ndim != 2 or takeoffs.shape[1] != 2 or len(takeoffs) == 0:
        raise ValueError(f"takeoff_xy_m must have shape (2,) or (v, 2), got {takeoffs.shape}")
    if not (np.isfinite(sites).all() and np.isfinite(takeoffs).all()):
        raise ValueError("sites_xy_m and takeoff_xy_m must be finite")
    if coordinators < 0:
        raise ValueError(f"coordinators must be >= 0, got {coordinators}")
    n = len(sites)
    if level is None:
        gaps = np.linalg.norm(sites[:, None, :] - takeoffs[None, :, :], axis=2)
        levels = np.argmin(gaps, axis=1) if n else np.zeros(0, dtype=int)
    else:
        levels = np.asarray(level)
        if levels.shape != (n,) or not np.issubdtype(levels.dtype, np.integer):
            raise ValueError(f"level must be ({n},) integers, got {levels.shape} {levels.dtype}")
        if n and (levels.min() < 0 or levels.max() >= len(takeoffs)):
            raise ValueError(
                f"level values must index the {len(takeoffs)} takeoff locations, "
                f"got {levels.min()}..{levels.max()}"
            )
    roles = [Role.OPERATOR] * n
    for lv in np.unique(levels):
        members = np.flatnonzero(levels == lv)  # ascending: stable sorts break ties by index
        to_p0 = np.linalg.norm(sites[members] - takeoffs[lv], axis=1)
        master = members[np.argsort(to_p0, kind="stable")[0]]
        roles[master] = Role.MASTER
        others = members[members != master]
        to_master = np.linalg.norm(sites[others] - sites[master], axis=1)
        for k in others[np.argsort(to_master, kind="stable")[:coordinators]]:
            roles[k] = Role.COORDINATOR
    return roles
