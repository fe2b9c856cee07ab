"""An airframe's kinematic limits: what the swarm-scale engine lets a point-mass vehicle do.

The optional ``kinematics`` section of an airframe YAML. The numbers are the limits PX4's
multicopter position controller flies the full-stack vehicle with (its MPC_* parameters), so that
a kinematic vehicle covers ground about as fast as the emulated one (docs/swarm.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path

import yaml

from sitl.vehicles.multirotor import airframe_yaml_path


@dataclass(frozen=True)
class KinematicLimits:
    """Speed, acceleration and turn-rate limits of one airframe, SI units."""

    max_speed_m_s: float
    """Horizontal speed limit, m/s (PX4 MPC_XY_VEL_MAX)."""
    max_accel_m_s2: float
    """Horizontal acceleration limit, m/s^2 (MPC_ACC_HOR): speed changes and turns."""
    max_turn_rate_deg_s: float
    """Course (heading of the velocity) rate limit, deg/s (MPC_YAWRAUTO_MAX)."""
    max_climb_m_s: float
    """Climb rate limit, m/s (MPC_Z_VEL_MAX_UP)."""
    max_descent_m_s: float
    """Descent rate limit, m/s (MPC_Z_VEL_MAX_DN)."""
    max_vertical_accel_m_s2: float
    """Vertical acceleration limit, m/s^2 (MPC_ACC_UP_MAX)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"kinematics.{f.name}: must be a positive number, got {value!r}")


def load_kinematic_limits(name: str | Path) -> KinematicLimits:
    """The ``kinematics`` section of an airframe (a name of ``sitl/vehicles`` or a folder).

    Raises:
        ValueError: an unknown airframe, no ``kinematics`` section, or a missing, unknown or
            non-positive key (naming the file and the key).
    """
    path = airframe_yaml_path(name)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML ({exc})") from exc
    section = data.get("kinematics") if isinstance(data, dict) else None
    if not isinstance(section, dict):
        raise ValueError(
            f"{path}: no 'kinematics' section (speed, acceleration and turn-rate limits): "
            "this airframe cannot fly at fidelity swarm"
        )
    names = {f.name for f in fields(KinematicLimits)}
    values = {k: v for k, v in section.items() if k != "description"}
    unknown, missing = sorted(set(values) - names), sorted(names - set(values))
    if unknown or missing:
        raise ValueError(f"{path}: section 'kinematics': missing keys {missing}, unknown {unknown}")
    try:
        return KinematicLimits(**values)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
