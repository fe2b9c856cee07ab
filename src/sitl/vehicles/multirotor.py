"""Multirotor airframes as data: ``vehicles/<name>/<name>.yaml`` + ``<name>.urdf``.

A multirotor is its rotor layout table plus motor, drag and sensor parameters (the YAML), and one
rigid body with collision shapes (the URDF, which owns mass and inertia).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sitl.physics.drag import FuselageDrag
from sitl.physics.earth import GRAVITY_M_S2
from sitl.physics.rotors import MotorParams, RotorSpec, Spin
from sitl.sensors.baro import BaroParams
from sitl.sensors.gps import GpsParams
from sitl.sensors.imu import ImuParams
from sitl.sensors.mag import MagParams
from sitl.vehicles.urdf import inspect_urdf

AIRFRAME_DIR = Path(__file__).resolve().parent
"""Folder holding one sub-folder per airframe."""


@dataclass(frozen=True)
class MultirotorSpec:
    """Everything the simulator knows about one multirotor airframe."""

    name: str
    """Airframe name (folder and file stem)."""
    description: str
    """One-paragraph description from the YAML."""
    source: str
    """Where the numbers come from."""
    yaml_path: Path
    """The YAML file."""
    urdf_path: Path
    """The URDF file loaded into PyBullet."""
    mass_kg: float
    """Total mass (from the URDF), kg."""
    inertia_diag_kg_m2: tuple[float, float, float]
    """Principal moments of inertia about the centre of mass, FLU axes (from the URDF), kg m^2."""
    ground_clearance_m: float
    """Height of the centre of mass above flat ground when resting level on it, m."""
    motor: MotorParams
    """Motor and propeller parameters, shared by every rotor."""
    rotors: tuple[RotorSpec, ...]
    """Rotor layout table, ordered by actuator output."""
    fuselage: FuselageDrag
    """Quadratic parasite drag per body axis."""
    imu: ImuParams
    """IMU noise."""
    mag: MagParams
    """Magnetometer noise."""
    baro: BaroParams
    """Barometer noise."""
    gps: GpsParams
    """GNSS error model."""

    @property
    def hover_speed_rad_s(self) -> float:
        """Rotor speed at which all rotors together carry the weight, rad/s."""
        k_f = self.motor.thrust_coefficient_n_s2_rad2
        return float(np.sqrt(self.mass_kg * GRAVITY_M_S2 / (len(self.rotors) * k_f)))

    @property
    def hover_command(self) -> float:
        """Normalised motor command of hover, ``hover_speed_rad_s / max_speed_rad_s``."""
        return self.hover_speed_rad_s / self.motor.max_speed_rad_s


def available_airframes() -> list[str]:
    """Names of the airframes shipped in ``sitl/vehicles``."""
    return sorted(
        d.name for d in AIRFRAME_DIR.iterdir() if d.is_dir() and (d / f"{d.name}.yaml").is_file()
    )


def _build(cls: type, data: Any, section: str, path: Path) -> Any:
    """Construct dataclass ``cls`` from a YAML mapping, with errors that name file and section."""
    if not isinstance(data, dict):
        raise ValueError(f"{path}: section '{section}' must be a mapping")
    names = {f.name for f in dataclasses.fields(cls)}
    values = {k: v for k, v in data.items() if k != "description"}
    unknown = sorted(set(values) - names)
    missing = sorted(names - set(values))
    if unknown or missing:
        raise ValueError(f"{path}: section '{section}': missing keys {missing}, unknown {unknown}")
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: section '{section}': {exc}") from exc


def _rotors(data: Any, path: Path) -> tuple[RotorSpec, ...]:
    if not isinstance(data, list) or not data:
        raise ValueError(f"{path}: 'rotors' must be a non-empty list")
    rotors = []
    for i, row in enumerate(data):
        try:
            rotors.append(
                RotorSpec(
                    output=int(row["output"]),
                    position_frd_m=(float(row["x_m"]), float(row["y_m"]), float(row["z_m"])),
                    spin=Spin(str(row["spin"]).lower()),
                )
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(
                f"{path}: rotors[{i}] needs output, x_m, y_m, z_m and spin (cw|ccw): {exc}"
            ) from exc
    rotors.sort(key=lambda r: r.output)
    if [r.output for r in rotors] != list(range(len(rotors))):
        raise ValueError(f"{path}: rotor outputs must be 0..{len(rotors) - 1}, each once")
    if len(rotors) > 16:
        raise ValueError(f"{path}: HIL_ACTUATOR_CONTROLS carries at most 16 outputs")
    return tuple(rotors)


def load_airframe(name: str) -> MultirotorSpec:
    """Load airframe ``name`` from ``sitl/vehicles/<name>/``.

    Raises:
        ValueError: for an unknown name (listing the known ones) or a broken YAML/URDF (naming the
            file).
    """
    known = available_airframes()
    if name not in known:
        raise ValueError(f"unknown airframe {name!r}; available: {', '.join(known)}")
    yaml_path = AIRFRAME_DIR / name / f"{name}.yaml"
    try:
        data = yaml.safe_load(yaml_path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{yaml_path}: not valid YAML ({exc})") from exc
    if not isinstance(data, dict):
        raise ValueError(f"{yaml_path}: expected a mapping at the top level")
    try:
        urdf_path = (yaml_path.parent / str(data["urdf"])).resolve()
        sections = {key: data[key] for key in ("motor", "fuselage", "imu", "mag", "baro", "gps")}
        rotor_rows = data["rotors"]
    except (KeyError, TypeError, IndexError, ValueError) as exc:
        raise ValueError(
            f"{yaml_path}: needs urdf, rotors, motor, fuselage, imu, mag, baro and gps ({exc!r})"
        ) from exc
    body = inspect_urdf(urdf_path)
    return MultirotorSpec(
        name=name,
        description=str(data.get("description", "")).strip(),
        source=str(data.get("source", "")).strip(),
        yaml_path=yaml_path,
        urdf_path=urdf_path,
        mass_kg=body.mass_kg,
        inertia_diag_kg_m2=body.inertia_diag_kg_m2,
        ground_clearance_m=-body.lowest_point_m,
        motor=_build(MotorParams, sections["motor"], "motor", yaml_path),
        rotors=_rotors(rotor_rows, yaml_path),
        fuselage=_build(FuselageDrag, sections["fuselage"], "fuselage", yaml_path),
        imu=_build(ImuParams, sections["imu"], "imu", yaml_path),
        mag=_build(MagParams, sections["mag"], "mag", yaml_path),
        baro=_build(BaroParams, sections["baro"], "baro", yaml_path),
        gps=_build(GpsParams, sections["gps"], "gps", yaml_path),
    )
