"""Seed 004's world abstraction (Sec. 4.2.1): camera footprint, workspace, grid of free waypoints.

The workspace is a polygon whose interior rings are no-fly holes, plus zones of low interest
(ZLIs). A lattice of cells one effective camera footprint in size (Eq. 1 less the overlaps) is
laid over the polygon's bounding box; a cell's centre is a waypoint when it lies in the polygon,
not in a hole, and outside every ZLI (P2: ZLI cells are removed). Frame: east x, north y, metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon


@dataclass(frozen=True)
class Camera:
    """The down-looking camera every MAV carries (P9); defaults are seed 004's, Sec. 5."""

    aov_deg: float = 87.0
    """Angle of view across the image width, degrees, in (0, 180)."""
    width_px: int = 4000
    """Image width I_x, pixels."""
    height_px: int = 3000
    """Image height I_y, pixels."""
    gsd_m: float = 0.02
    """Ground sample distance wanted, m per pixel."""

    def __post_init__(self) -> None:
        if not 0.0 < self.aov_deg < 180.0:
            raise ValueError(f"aov_deg must be in (0, 180), got {self.aov_deg!r}")
        if self.width_px <= 0 or self.height_px <= 0:
            raise ValueError(
                f"width_px and height_px must be positive, got {self.width_px!r} x "
                f"{self.height_px!r}"
            )
        if not (math.isfinite(self.gsd_m) and self.gsd_m > 0.0):
            raise ValueError(f"gsd_m must be positive, got {self.gsd_m!r}")

    def altitude_m(self) -> float:
        """Height giving ``gsd_m``: Eq. (1) solved for h with L_x = I_x * GSD, seed 004."""
        footprint_x = self.width_px * self.gsd_m
        return footprint_x / (2.0 * math.tan(math.radians(self.aov_deg) / 2.0))

    def footprint_m(self, altitude_m: float) -> tuple[float, float]:
        """Ground footprint (L_x, L_y) at ``altitude_m``, m; Eq. (1), seed 004, typo fixed.

        L_x = 2 h tan(alpha / 2); L_y = L_x I_y / I_x (the printed L_y = L_y (I_x / I_y) is a typo:
        the footprint has the image's aspect ratio).
        """
        if not (math.isfinite(altitude_m) and altitude_m > 0.0):
            raise ValueError(f"altitude_m must be positive, got {altitude_m!r}")
        footprint_x = 2.0 * altitude_m * math.tan(math.radians(self.aov_deg) / 2.0)
        return footprint_x, footprint_x * self.height_px / self.width_px


@dataclass(frozen=True)
class Workspace:
    """The area to cover: a polygon (interior rings are no-fly holes) and zones of low interest."""

    polygon: Polygon
    """Area to cover, ENU m; its interior rings are no-fly holes."""
    zli: tuple[Polygon, ...] = ()
    """Zones of low interest (obstacles or no-care areas), removed from the grid (P2)."""

    def __post_init__(self) -> None:
        if self.polygon.is_empty or self.polygon.area <= 0.0:
            raise ValueError(f"polygon must have a positive area, got {self.polygon.wkt[:80]!r}")

    @classmethod
    def from_world(cls, world: Any) -> Workspace:
        """The workspace of a built ``worlds`` World (``workspace_mco``: no-fly are holes)."""
        return cls(polygon=world.boundary, zli=tuple(world.low_interest))

    @property
    def width_m(self) -> float:
        """East-west extent of the polygon's bounding box, m (seed 004's "measured width")."""
        x0, _, x1, _ = self.polygon.bounds
        return float(x1 - x0)


@dataclass(frozen=True)
class Grid:
    """Free waypoints of the workspace: centres of the free cells of one lattice."""

    waypoints_xy_m: np.ndarray
    """(K, 2) free cell centres (east, north), m; row by row south to north, west to east."""
    row: np.ndarray
    """(K,) lattice row (north index) of each waypoint."""
    col: np.ndarray
    """(K,) lattice column (east index) of each waypoint."""
    cell_m: tuple[float, float]
    """Lattice step (L_x (1 - p), L_y (1 - q)), m."""
    origin_xy_m: tuple[float, float]
    """Centre of lattice cell (row 0, col 0), m."""
    zli_cells: int
    """Cells in the polygon removed because their centre lies in a ZLI."""
    hole_cells: int
    """Cells inside the outer ring removed because their centre lies in a hole."""

    def __len__(self) -> int:
        return int(self.waypoints_xy_m.shape[0])


def build_grid(
    workspace: Workspace,
    camera: Camera,
    altitude_m: float | None = None,
    overlap: tuple[float, float] = (0.75, 0.75),
) -> Grid:
    """Free waypoints of ``workspace`` for ``camera`` at ``altitude_m`` (default: its GSD height).

    Sec. 4.2.1, seed 004: cell = (L_x (1 - p), L_y (1 - q)) with the footprint of Eq. (1), p the
    overlap along east and q along north; the lattice starts at the bounding box's south-west
    corner. A cell is free when its centre is inside the polygon (not in a hole, not on its edge)
    and outside every ZLI (P2).
    """
    p, q = overlap
    for name, value in (("overlap[0]", p), ("overlap[1]", q)):
        if not 0.0 <= value < 1.0:
            raise ValueError(f"{name} must be in [0, 1), got {value!r}")
    height = camera.altitude_m() if altitude_m is None else altitude_m
    footprint_x, footprint_y = camera.footprint_m(height)
    dx, dy = footprint_x * (1.0 - p), footprint_y * (1.0 - q)
    x0, y0, x1, y1 = workspace.polygon.bounds
    n_col = max(1, math.ceil((x1 - x0) / dx - 1e-9))
    n_row = max(1, math.ceil((y1 - y0) / dy - 1e-9))
    rows, cols = np.meshgrid(np.arange(n_row), np.arange(n_col), indexing="ij")
    rows, cols = rows.ravel(), cols.ravel()
    xs = x0 + (cols + 0.5) * dx
    ys = y0 + (rows + 0.5) * dy
    in_shell = shapely.contains_xy(Polygon(workspace.polygon.exterior), xs, ys)
    in_polygon = shapely.contains_xy(workspace.polygon, xs, ys)
    in_zli = np.zeros_like(in_polygon)
    for zone in workspace.zli:
        in_zli |= shapely.intersects_xy(zone, xs, ys)
    free = in_polygon & ~in_zli
    if not free.any():
        raise ValueError(
            f"the workspace has no free cell for a {dx:.3g} m x {dy:.3g} m lattice "
            f"(polygon bounds {workspace.polygon.bounds})"
        )
    return Grid(
        waypoints_xy_m=np.column_stack([xs[free], ys[free]]),
        row=rows[free].astype(np.int64),
        col=cols[free].astype(np.int64),
        cell_m=(dx, dy),
        origin_xy_m=(x0 + 0.5 * dx, y0 + 0.5 * dy),
        zli_cells=int(np.count_nonzero(in_polygon & in_zli)),
        hole_cells=int(np.count_nonzero(in_shell & ~in_polygon)),
    )


def default_takeoff_xy_m(grid: Grid) -> np.ndarray:
    """Default take-off p0: the free waypoint nearest the mean of the free waypoints, m.

    Seed 004, Phase I: p0 "could be the center of the coverage area"; snapping it to a free
    waypoint keeps it inside a concave or holed workspace.
    """
    xy = grid.waypoints_xy_m
    return xy[int(np.argmin(np.sum((xy - xy.mean(axis=0)) ** 2, axis=1)))].copy()
