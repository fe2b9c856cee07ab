"""The frozen description of a built world: solids, surface, launch areas, targets, zones.

Everything is in the world's ENU frame (x east, y north, z up, metres), the ground or sea at z = 0,
the world's extent centred on the origin. Solids are boxes or vertical cylinders with a yaw and an
RGBA colour, the shapes ``sitl.physics.obstacles.BoxObstacle`` takes (a cylinder is a
``GEOM_CYLINDER`` of the given diameter and height). Whatever changes with time (moving obstacles,
moving demand hotspots, spills appearing) is a pure function of simulation time ``t_s``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import shapely
from shapely.geometry import Polygon

RGBA = tuple[float, float, float, float]
XY = tuple[float, float]
XYZ = tuple[float, float, float]


def bounce(
    start: np.ndarray, velocity: np.ndarray, low: np.ndarray, high: np.ndarray, t_s: float
) -> np.ndarray:
    """Position at ``t_s`` of a point moving at constant velocity, reflecting off a box's walls.

    Pure and vectorised: ``start``, ``velocity``, ``low`` and ``high`` broadcast against each other
    (e.g. shape (N, 2) for N movers); the path is a triangle wave inside ``[low, high]``.
    """
    span = np.maximum(high - low, 1e-12)
    unfolded = np.mod(start - low + velocity * t_s, 2.0 * span)
    return low + np.where(unfolded > span, 2.0 * span - unfolded, unfolded)


@dataclass(frozen=True)
class SolidMotion:
    """Straight motion reflecting off a rectangle, plus a vertical sine (seed 001's movers)."""

    velocity_xy_m_s: XY
    """Horizontal velocity, m/s."""
    bounds_xy_m: tuple[float, float, float, float]
    """Rectangle (x_min, y_min, x_max, y_max) the centre stays in, m."""
    vertical_amplitude_m: float = 0.0
    """Amplitude of the centre's vertical sine, m."""
    vertical_period_s: float = 60.0
    """Period of the vertical sine, s (> 0)."""
    phase_rad: float = 0.0
    """Phase of the vertical sine, rad."""


@dataclass(frozen=True)
class Solid:
    """A box or vertical cylinder: something rangefinders hit, cameras see and planners avoid."""

    name: str
    """What it is, e.g. ``"rig_deck"``, ``"building_3"``, ``"wall"``."""
    shape: Literal["box", "cylinder"]
    """``box``: ``size_m`` = extents along its x, y, z; ``cylinder``: (diameter, diameter, h)."""
    center_enu_m: XYZ
    """Centre at t = 0, ENU, m."""
    size_m: XYZ
    """Full extents, m; each > 0."""
    yaw_deg: float = 0.0
    """Rotation about the vertical, counter-clockwise from east, degrees (ignored for cylinders)."""
    rgba: RGBA = (0.55, 0.55, 0.58, 1.0)
    """Colour the cameras see, each channel in [0, 1]."""
    motion: SolidMotion | None = None
    """How it moves; ``None`` for static solids."""

    def __post_init__(self) -> None:
        if self.shape not in ("box", "cylinder"):
            raise ValueError(f"Solid.shape must be 'box' or 'cylinder', got {self.shape!r}")
        if not all(s > 0.0 and math.isfinite(s) for s in self.size_m):
            raise ValueError(f"Solid.size_m must be positive, got {self.size_m}")
        if not all(0.0 <= c <= 1.0 for c in self.rgba):
            raise ValueError(f"Solid.rgba channels must be in [0, 1], got {self.rgba}")

    def center_at(self, t_s: float) -> XYZ:
        """Centre at simulation time ``t_s``, ENU, m."""
        if self.motion is None:
            return self.center_enu_m
        x, y, z = motion_centers([self], t_s)[0]
        return (float(x), float(y), float(z))

    def z_range_at(self, t_s: float) -> tuple[float, float]:
        """(bottom, top) at ``t_s``, m."""
        z = self.center_at(t_s)[2]
        return (z - self.size_m[2] / 2.0, z + self.size_m[2] / 2.0)

    def footprint_at(self, t_s: float = 0.0) -> Polygon:
        """Its outline seen from above at ``t_s`` (a rotated rectangle or a 32-gon)."""
        cx, cy, _ = self.center_at(t_s)
        if self.shape == "cylinder":
            return shapely.Point(cx, cy).buffer(self.size_m[0] / 2.0, quad_segs=8)
        hx, hy = self.size_m[0] / 2.0, self.size_m[1] / 2.0
        c, s = math.cos(math.radians(self.yaw_deg)), math.sin(math.radians(self.yaw_deg))
        corners = [(-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy)]
        return Polygon([(cx + c * x - s * y, cy + s * x + c * y) for x, y in corners])


def motion_centers(solids: Sequence[Solid], t_s: float) -> np.ndarray:
    """(K, 3) centres at ``t_s`` of moving solids (each with a ``motion``), m; vectorised.

    The one motion law of moving solids (:class:`SolidMotion`): straight lines reflecting off the
    bounds (:func:`bounce`), plus the vertical sine.
    """
    motions = [s.motion for s in solids if s.motion is not None]
    if len(motions) != len(solids):
        raise ValueError("motion_centers takes moving solids only")
    c0 = np.array([s.center_enu_m for s in solids], dtype=float).reshape(-1, 3)
    vel = np.array([m.velocity_xy_m_s for m in motions], dtype=float).reshape(-1, 2)
    b = np.array([m.bounds_xy_m for m in motions], dtype=float).reshape(-1, 4)
    amp = np.array([m.vertical_amplitude_m for m in motions], dtype=float)
    period = np.array([m.vertical_period_s for m in motions], dtype=float)
    phase = np.array([m.phase_rad for m in motions], dtype=float)
    xy = bounce(c0[:, :2], vel, b[:, :2], b[:, 2:], t_s)
    z = c0[:, 2] + amp * np.sin(2.0 * np.pi * t_s / period + phase)
    return np.column_stack((xy, z))


@dataclass(frozen=True)
class Surface:
    """The sea or the ground at z = 0: what the cameras see below everything else."""

    kind: Literal["sea", "ground", "floor"]
    """Sea (offshore), ground (city, arenas) or indoor floor."""
    rgba: RGBA
    """Base colour."""
    texture: str
    """Procedural texture name for the renderer: ``waves``, ``asphalt``, ``grass``, ``concrete``."""
    texture_scale_m: float
    """Size of one texture feature (wave length, tile), m."""
    texture_contrast: float
    """Brightness variation of the texture, 0 (flat colour) to 1."""
    wave_amplitude_m: float = 0.0
    """Visual wave height for the sea, m (not a physics surface)."""


@dataclass(frozen=True)
class LaunchArea:
    """Where vehicles start or go home: a helideck, a land base, a safe point, a start zone."""

    name: str
    """``helideck``, ``land_base``, ``safe_point``, ``start``, ``goal``, ``agent_start_<i>``."""
    center_enu_m: XYZ
    """Centre of the pad's surface (z = its height, e.g. the helideck), m."""
    radius_m: float
    """Usable radius, m."""


@dataclass(frozen=True)
class OilSpill:
    """A dark, irregular patch on the sea that appears at ``appear_s`` (seed 000 S1)."""

    name: str
    outline_xy_m: tuple[XY, ...]
    """Polygon vertices, m."""
    appear_s: float
    """Simulation time it appears, s."""
    rgba: RGBA = (0.06, 0.05, 0.05, 1.0)

    @property
    def polygon(self) -> Polygon:
        """The outline as a shapely polygon."""
        return Polygon(self.outline_xy_m)

    def visible_at(self, t_s: float) -> bool:
        """Whether it exists at ``t_s``."""
        return t_s >= self.appear_s


@dataclass(frozen=True)
class Person:
    """A person to find indoors (seed 000 S3): standing or lying at ``position_enu_m``."""

    name: str
    position_enu_m: XYZ
    height_m: float = 1.7
    rgba: RGBA = (0.95, 0.45, 0.1, 1.0)


@dataclass(frozen=True)
class Hotspot:
    """A circular area of client demand moving, reflecting off the bounds (seed 000 S2)."""

    name: str
    center_xy_m: XY
    """Centre at t = 0, m."""
    radius_m: float
    velocity_xy_m_s: XY
    bounds_xy_m: tuple[float, float, float, float]
    demand: float = 1.0

    def center_at(self, t_s: float) -> XY:
        """Centre at ``t_s``, m."""
        b = np.asarray(self.bounds_xy_m, dtype=float)
        xy = bounce(
            np.asarray(self.center_xy_m), np.asarray(self.velocity_xy_m_s), b[:2], b[2:], t_s
        )
        return (float(xy[0]), float(xy[1]))


@dataclass(frozen=True)
class TaskPoint:
    """A stationary task on a grid vertex with a demand (seed 003's task maps)."""

    name: str
    position_xy_m: XY
    demand: float


Target = OilSpill | Person | Hotspot | TaskPoint


@dataclass(frozen=True)
class Wind:
    """A wind hint for the simulator: mean speed, the direction it blows FROM, gust spread."""

    speed_m_s: float
    from_direction_deg: float
    """Compass-style: 0 = from north, 90 = from east."""
    gust_std_m_s: float

    @property
    def velocity_enu_m_s(self) -> XYZ:
        """The air's velocity vector, ENU, m/s."""
        a = math.radians(self.from_direction_deg)
        return (-self.speed_m_s * math.sin(a), -self.speed_m_s * math.cos(a), 0.0)


@dataclass(frozen=True)
class World:
    """A built world: pure data, the same for the same spec and seed."""

    kind: str
    seed: int
    size_m: XY
    """Extent along x and y, m; the world spans [-size/2, +size/2] around the origin."""
    boundary: Polygon
    """Where vehicles may be: the extent's rectangle, or seed 004's workspace polygon with holes."""
    surface: Surface
    solids: tuple[Solid, ...] = ()
    launch_areas: tuple[LaunchArea, ...] = ()
    targets: tuple[Target, ...] = ()
    no_fly: tuple[Polygon, ...] = ()
    """Areas vehicles must not enter (besides solids), e.g. workspace holes."""
    low_interest: tuple[Polygon, ...] = ()
    """Seed 004's zones of low interest: flyable, not worth covering."""
    gps_denied: bool = False
    wind: Wind | None = None
    extras: dict[str, float] = field(default_factory=dict)
    """Kind-specific numbers worth keeping (e.g. ``grid_spacing_m`` of a task map)."""

    @property
    def bounds_xy_m(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the extent, m."""
        return (
            -self.size_m[0] / 2.0,
            -self.size_m[1] / 2.0,
            self.size_m[0] / 2.0,
            self.size_m[1] / 2.0,
        )

    def launch_area(self, name: str) -> LaunchArea:
        """The launch area called ``name``; ``KeyError`` naming the ones there are otherwise."""
        for area in self.launch_areas:
            if area.name == name:
                return area
        raise KeyError(f"no launch area {name!r}; there are {[a.name for a in self.launch_areas]}")

    def targets_of(self, kind: type) -> list:
        """The targets of one class, e.g. ``world.targets_of(OilSpill)``."""
        return [t for t in self.targets if isinstance(t, kind)]

    def spills_at(self, t_s: float) -> list[OilSpill]:
        """The oil spills that exist at ``t_s``."""
        return [s for s in self.targets_of(OilSpill) if s.visible_at(t_s)]

    def solids_at(self, t_s: float) -> list[Solid]:
        """Every solid placed where it is at ``t_s`` (moving ones as static copies)."""
        out = []
        for s in self.solids:
            if s.motion is None:
                out.append(s)
            else:
                out.append(
                    Solid(s.name, s.shape, s.center_at(t_s), s.size_m, s.yaw_deg, s.rgba, None)
                )
        return out
