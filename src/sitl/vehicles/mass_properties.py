"""Composite mass properties of a rigid assembly of links (the SDF's links, lumped into one body).

For links ``i`` of mass ``m_i``, centre of mass ``p_i`` and inertia ``I_i`` about their own centre
of mass in axes rotated by ``R_i`` from the model axes:

    m = sum m_i,    c = sum m_i p_i / m,
    I_c = sum [ R_i I_i R_i^T + m_i (|d_i|^2 E - d_i d_i^T) ],   d_i = p_i - c

(rotation of an inertia tensor, and the parallel-axis theorem of Huygens-Steiner; e.g. Goldstein,
"Classical Mechanics", 3rd ed., sec. 5.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LinkInertial:
    """Mass properties of one link, in the model frame."""

    name: str
    """Link name in the source model."""
    mass_kg: float
    """Mass, kg."""
    position_m: tuple[float, float, float]
    """Centre of mass in the model frame (SDF: link pose composed with the inertial pose), m."""
    rpy_rad: tuple[float, float, float]
    """Orientation of the inertia axes in the model frame, fixed-axis roll, pitch, yaw, rad."""
    inertia_kg_m2: tuple[float, float, float, float, float, float]
    """Inertia about the link's centre of mass in its own axes: ixx, iyy, izz, ixy, ixz, iyz."""

    def __post_init__(self) -> None:
        if not self.mass_kg > 0.0:
            raise ValueError(f"link {self.name!r}: mass_kg must be positive, got {self.mass_kg!r}")
        if len(self.position_m) != 3 or len(self.rpy_rad) != 3 or len(self.inertia_kg_m2) != 6:
            raise ValueError(
                f"link {self.name!r}: needs position_m [x, y, z], rpy_rad [r, p, y] and "
                "inertia_kg_m2 [ixx, iyy, izz, ixy, ixz, iyz]"
            )


@dataclass(frozen=True)
class CompositeBody:
    """Mass, centre of mass and inertia tensor of an assembly of links."""

    mass_kg: float
    """Total mass, kg."""
    center_of_mass_m: np.ndarray
    """Centre of mass in the model frame, m, (3,)."""
    inertia_kg_m2: np.ndarray
    """Inertia tensor about the centre of mass in the model axes, kg m^2, (3, 3)."""


def rotation_from_rpy(rpy_rad: tuple[float, float, float] | np.ndarray) -> np.ndarray:
    """SDF/URDF fixed-axis roll-pitch-yaw to a rotation matrix, ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    roll, pitch, yaw = (float(a) for a in rpy_rad)
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def inertia_matrix(inertia_kg_m2: tuple[float, ...]) -> np.ndarray:
    """Symmetric 3x3 tensor from ``(ixx, iyy, izz, ixy, ixz, iyz)``."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(v) for v in inertia_kg_m2)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def composite_body(links: tuple[LinkInertial, ...] | list[LinkInertial]) -> CompositeBody:
    """Lump rigidly joined links into one body (see the module equations)."""
    if not links:
        raise ValueError("no links to lump")
    masses = np.array([link.mass_kg for link in links])
    positions = np.array([link.position_m for link in links], dtype=float)
    mass = float(masses.sum())
    com = masses @ positions / mass
    inertia = np.zeros((3, 3))
    for link, m, p in zip(links, masses, positions, strict=True):
        r = rotation_from_rpy(link.rpy_rad)
        d = p - com
        inertia += r @ inertia_matrix(link.inertia_kg_m2) @ r.T
        inertia += m * (float(d @ d) * np.eye(3) - np.outer(d, d))
    return CompositeBody(mass_kg=mass, center_of_mass_m=com, inertia_kg_m2=inertia)
