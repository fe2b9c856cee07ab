"""Electrical power drawn by the rotors, and the rotor speed a pack voltage allows.

Propeller (momentum theory, Leishman, "Principles of Helicopter Aerodynamics", 2nd ed. 2006,
Eqs. 2.15 and 2.46): a rotor of disc area A producing thrust T in hover needs the ideal induced
power ``T^1.5 / sqrt(2 rho A)``; a real propeller needs that divided by its figure of merit FM
(profile drag, tip losses, swirl). Motor and ESC: the shaft power costs ``1 / eta`` of electrical
power (copper, iron and switching losses lumped into one efficiency). With the thrust of the rotor
model ``T = k_f w^2`` the electrical power of one rotor is::

    P_e = k_f^1.5 w^3 / (FM * eta * sqrt(2 rho A))

i.e. a cubic in rotor speed like Gazebo's ``k_m w^3``, but with a physical constant: Gazebo's
``momentConstant * k_f`` is a yaw-moment constant, about 4x the aerodynamic torque of momentum
theory at FM 0.6 for the Typhoon's constants (it would give ~1.1 kW at hover). The model is the
hover one; climb and forward flight (which lower the induced power) are not modelled.

Rotor speed limit: a brushless motor's no-load speed is Kv x V, so the speed at full command
scales with the terminal voltage: ``w_max(V) = max_speed_rad_s * V / max_speed_voltage_v``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from sitl.power.battery import LipoParams


@dataclass(frozen=True)
class PropulsionParams:
    """Propeller, motor and ESC constants of an airframe (its YAML ``power`` block)."""

    rotor_diameter_m: float
    """Propeller diameter, m."""
    figure_of_merit: float
    """Hover figure of merit of the propeller, ideal induced power / shaft power (0..1)."""
    motor_esc_efficiency: float
    """Shaft power / electrical power drawn from the pack by motor and ESC (0..1)."""
    max_speed_voltage_v: float
    """Pack terminal voltage at which a full command gives the motor model's max speed, V."""

    def __post_init__(self) -> None:
        if not self.rotor_diameter_m > 0.0:
            raise ValueError(f"rotor_diameter_m must be positive, got {self.rotor_diameter_m!r}")
        for name in ("figure_of_merit", "motor_esc_efficiency"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in (0, 1], got {getattr(self, name)!r}")
        if not self.max_speed_voltage_v > 0.0:
            raise ValueError(f"max_speed_voltage_v must be positive: {self.max_speed_voltage_v!r}")

    @property
    def disc_area_m2(self) -> float:
        """Rotor disc area, m^2."""
        return math.pi * self.rotor_diameter_m**2 / 4.0

    def hover_power_w(self, thrust_n: np.ndarray | float, air_density_kg_m3: float) -> np.ndarray:
        """Electrical power of rotors producing ``thrust_n`` each (summed over the last axis), W."""
        t = np.maximum(np.asarray(thrust_n, dtype=float), 0.0)
        ideal = t**1.5 / math.sqrt(2.0 * air_density_kg_m3 * self.disc_area_m2)
        return np.sum(ideal, axis=-1) / (self.figure_of_merit * self.motor_esc_efficiency)

    def power_coefficient_w_s3_rad3(
        self, thrust_coefficient_n_s2_rad2: float, air_density_kg_m3: float
    ) -> float:
        """``P_e / w^3`` of one rotor for thrust ``k_f w^2``, W/(rad/s)^3."""
        return thrust_coefficient_n_s2_rad2**1.5 / (
            self.figure_of_merit
            * self.motor_esc_efficiency
            * math.sqrt(2.0 * air_density_kg_m3 * self.disc_area_m2)
        )


@dataclass(frozen=True)
class PowerSpec:
    """The ``power`` block of an airframe YAML: propulsion constants and the battery."""

    propulsion: PropulsionParams
    battery: LipoParams


def _build(cls: type, data: Any, section: str, path: Path) -> Any:
    if not isinstance(data, dict):
        raise ValueError(f"{path}: section '{section}' must be a mapping")
    names = {f.name for f in fields(cls)}
    values = {k: v for k, v in data.items() if k in names}
    missing = sorted(names - set(values))
    if missing:
        raise ValueError(f"{path}: section '{section}': missing keys {missing}")
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: section '{section}': {exc}") from exc


def load_power_spec(yaml_path: Path) -> PowerSpec:
    """Read the ``power`` block of an airframe YAML (errors name the file and the section)."""
    try:
        data = yaml.safe_load(Path(yaml_path).read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{yaml_path}: not valid YAML ({exc})") from exc
    power = data.get("power") if isinstance(data, dict) else None
    if not isinstance(power, dict):
        raise ValueError(f"{yaml_path}: needs a 'power' section (propulsion constants, battery)")
    extra = sorted(
        set(power) - {f.name for f in fields(PropulsionParams)} - {"battery", "description"}
    )
    if extra:
        raise ValueError(f"{yaml_path}: section 'power': unknown keys {extra}")
    battery = power.get("battery")
    if isinstance(battery, dict):
        unknown = sorted(set(battery) - {f.name for f in fields(LipoParams)} - {"description"})
        if unknown:
            raise ValueError(f"{yaml_path}: section 'power.battery': unknown keys {unknown}")
    return PowerSpec(
        propulsion=_build(PropulsionParams, power, "power", yaml_path),
        battery=_build(LipoParams, battery, "power.battery", yaml_path),
    )
