"""What the simulator needs to know from an airframe URDF before PyBullet loads it."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class UrdfBody:
    """Mass properties and ground clearance of a single-link URDF."""

    mass_kg: float
    """Mass of the body, kg."""
    inertia_diag_kg_m2: tuple[float, float, float]
    """Principal moments of inertia about the centre of mass (ixx, iyy, izz), kg m^2."""
    lowest_point_m: float
    """Lowest z of any collision shape in the level body frame (negative), m."""


def _floats(text: str | None, count: int, what: str, path: Path) -> np.ndarray:
    try:
        values = np.array([float(v) for v in (text or "").split()])
    except ValueError as exc:
        raise ValueError(f"{path}: {what} is not a list of numbers: {text!r}") from exc
    if values.size != count:
        raise ValueError(f"{path}: {what} needs {count} numbers, got {text!r}")
    return values


def _rotation_rpy(rpy: np.ndarray) -> np.ndarray:
    """URDF fixed-axis roll-pitch-yaw to a rotation matrix (Rz @ Ry @ Rx)."""
    cr, sr = np.cos(rpy[0]), np.sin(rpy[0])
    cp, sp = np.cos(rpy[1]), np.sin(rpy[1])
    cy, sy = np.cos(rpy[2]), np.sin(rpy[2])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _lowest_z(collision: ET.Element, path: Path) -> float:
    origin = collision.find("origin")
    xyz = _floats(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0", 3, "xyz", path)
    rpy = _floats(origin.get("rpy", "0 0 0") if origin is not None else "0 0 0", 3, "rpy", path)
    up = _rotation_rpy(rpy)[2]  # z row: how each shape axis projects on world z
    geometry = collision.find("geometry")
    if geometry is None or len(geometry) != 1:
        raise ValueError(f"{path}: every <collision> needs exactly one <geometry> shape")
    shape = geometry[0]
    if shape.tag == "box":
        half = _floats(shape.get("size"), 3, "box size", path) / 2.0
        extent = float(np.abs(up) @ half)
    elif shape.tag == "cylinder":
        radius = float(_floats(shape.get("radius"), 1, "cylinder radius", path)[0])
        half_len = float(_floats(shape.get("length"), 1, "cylinder length", path)[0]) / 2.0
        extent = abs(up[2]) * half_len + radius * np.sqrt(max(0.0, 1.0 - up[2] ** 2))
    elif shape.tag == "sphere":
        extent = float(_floats(shape.get("radius"), 1, "sphere radius", path)[0])
    else:
        raise ValueError(f"{path}: collision shape <{shape.tag}> is not box, cylinder or sphere")
    return float(xyz[2]) - extent


def inspect_urdf(path: Path) -> UrdfBody:
    """Read mass, inertia and ground clearance of a single-link airframe URDF.

    Raises:
        ValueError: naming the file, if it is missing, not XML, or not a single rigid link whose
            inertial frame is the link frame with a diagonal inertia.
    """
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError as exc:
        raise ValueError(f"{path}: URDF file not found") from exc
    except ET.ParseError as exc:
        raise ValueError(f"{path}: not valid XML ({exc})") from exc
    links = root.findall("link")
    if root.tag != "robot" or len(links) != 1 or root.find("joint") is not None:
        raise ValueError(f"{path}: expected <robot> with exactly one <link> and no joints")
    link = links[0]
    inertial = link.find("inertial")
    if inertial is None or inertial.find("mass") is None or inertial.find("inertia") is None:
        raise ValueError(f"{path}: <link> needs <inertial> with <mass> and <inertia>")
    origin = inertial.find("origin")
    if origin is not None and (
        np.any(_floats(origin.get("xyz", "0 0 0"), 3, "inertial xyz", path) != 0.0)
        or np.any(_floats(origin.get("rpy", "0 0 0"), 3, "inertial rpy", path) != 0.0)
    ):
        raise ValueError(
            f"{path}: the inertial origin must be the link origin (the centre of mass): rotor "
            "positions are given relative to it"
        )
    mass = float(_floats(inertial.find("mass").get("value"), 1, "mass", path)[0])
    inertia = inertial.find("inertia")
    moments = []
    for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
        moments.append(float(_floats(inertia.get(key, "0"), 1, key, path)[0]))
    ixx, ixy, ixz, iyy, iyz, izz = moments
    if ixy or ixz or iyz:
        raise ValueError(f"{path}: products of inertia must be zero (principal body axes)")
    if not (mass > 0.0 and ixx > 0.0 and iyy > 0.0 and izz > 0.0):
        raise ValueError(f"{path}: mass and principal moments of inertia must be positive")
    collisions = link.findall("collision")
    if not collisions:
        raise ValueError(f"{path}: the link has no <collision> shape to stand on")
    lowest = min(_lowest_z(c, path) for c in collisions)
    return UrdfBody(mass_kg=mass, inertia_diag_kg_m2=(ixx, iyy, izz), lowest_point_m=float(lowest))
