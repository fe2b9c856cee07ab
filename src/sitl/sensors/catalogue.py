"""Named sensor classes (GNSS receivers, IMUs, barometers) with their datasheet figures.

An airframe YAML selects a class by name (``gps: {receiver: neo_m9n}``, ``imu: {sensor:
icm42688p}``, ``baro: {sensor: ms5611}``) and may override any model parameter next to it. The
figures live in ``catalogue.yaml`` in the units of their source document; this module converts
them to the models' SI parameters, once:

- GNSS: a datasheet's horizontal CEP50 (the radius holding half the fixes) of a circular
  Gaussian error with per-axis standard deviation ``sigma`` is ``sigma sqrt(2 ln 2) = 1.1774
  sigma``, so ``sigma = CEP50 / 1.1774``; a vertical R50 (half the errors smaller in magnitude)
  is ``0.6745 sigma_v``. The receiver model (gps.py) reports ``eph = HDOP UERE / sqrt(2)``; at
  the reference geometry that is ``sigma``, so ``UERE = sqrt(2) sigma / HDOP_ref``. u-blox's
  velocity figure (50 % at 30 m/s) is taken as a horizontal CEP50 of the velocity error too.
- IMU: densities in deg/s/sqrt(Hz) and ug/sqrt(Hz) to rad/s/sqrt(Hz) and m/s^2/sqrt(Hz)
  (1 g = 9.80665 m/s^2, the standard gravity the datasheets' g means); the typical initial
  offset tolerance (deg/s, mg) is taken as one standard deviation of the turn-on bias.
- Barometer: RMS noise in mbar to Pa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import yaml

CATALOGUE_PATH = Path(__file__).with_name("catalogue.yaml")
"""The data file of the classes."""

CEP50_PER_SIGMA = math.sqrt(2.0 * math.log(2.0))
"""CEP50 / per-axis sigma of a circular two-dimensional Gaussian (1.1774)."""
R50_PER_SIGMA = 0.6744897501960817
"""Median of |x| / sigma of a one-dimensional Gaussian (the 75th percentile of N(0, 1))."""
STANDARD_GRAVITY_M_S2 = 9.80665
"""1 g of a datasheet, m/s^2."""

_DATASHEET_UNITS: dict[str, tuple[str, float]] = {
    "gyro_noise_density_deg_s_sqrt_hz": ("gyro_noise_density_rad_s_sqrt_hz", math.pi / 180.0),
    "gyro_initial_offset_deg_s": ("gyro_turn_on_bias_sigma_rad_s", math.pi / 180.0),
    "accel_noise_density_ug_sqrt_hz": (
        "accel_noise_density_m_s2_sqrt_hz",
        1e-6 * STANDARD_GRAVITY_M_S2,
    ),
    "accel_initial_offset_mg": ("accel_turn_on_bias_sigma_m_s2", 1e-3 * STANDARD_GRAVITY_M_S2),
    "pressure_rms_noise_mbar": ("pressure_noise_pa", 100.0),
}
"""Datasheet key -> (model parameter, factor to SI)."""

_TEXT_KEYS = ("description", "source", "conditions")


@dataclass(frozen=True)
class GnssReceiverClass:
    """A GNSS receiver as its datasheet states its accuracy."""

    name: str
    """Catalogue name (what an airframe's ``gps.receiver`` says)."""
    description: str
    """The receiver and its mode."""
    source: str
    """Document and table the figures come from."""
    conditions: str
    """The datasheet's test conditions of the figures."""
    horizontal_cep50_m: float
    """Horizontal circular error probable, 50 %, m."""
    velocity_50_m_s: float
    """Velocity accuracy, 50 %, m/s."""
    vertical_r50_m: float | None = None
    """Vertical error, 50 %, m; None: the datasheet gives none (the sky's VDOP/HDOP is used)."""

    @property
    def horizontal_sigma_m(self) -> float:
        """Per-axis standard deviation of the horizontal error, m."""
        return self.horizontal_cep50_m / CEP50_PER_SIGMA

    def gps_params(self, sky: dict[str, Any]) -> dict[str, Any]:
        """The GpsParams fields of this receiver under the shared sky assumptions ``sky``."""
        sigma_h = self.horizontal_sigma_m
        hdop = float(sky["hdop_reference"])
        uere = math.sqrt(2.0) * sigma_h / hdop
        if self.vertical_r50_m is None:
            vdop_per_hdop = float(sky["vdop_per_hdop"])
        else:
            vdop_per_hdop = (self.vertical_r50_m / R50_PER_SIGMA) / (hdop * uere)
        sigma_v = vdop_per_hdop * hdop * uere
        white = float(sky["white_noise_fraction"])
        velocity_h = self.velocity_50_m_s / CEP50_PER_SIGMA
        return {
            "delay_ms": float(sky["delay_ms"]),
            "uere_m": uere,
            "hdop_reference": hdop,
            "satellites_reference": int(sky["satellites_reference"]),
            "vdop_per_hdop": vdop_per_hdop,
            "satellites_mean": float(sky["satellites_mean"]),
            "satellites_sigma": float(sky["satellites_sigma"]),
            "satellites_max": int(sky["satellites_max"]),
            "satellites_correlation_time_s": float(sky["satellites_correlation_time_s"]),
            "bias_correlation_time_s": float(sky["bias_correlation_time_s"]),
            "horizontal_noise_sigma_m": white * sigma_h,
            "vertical_noise_sigma_m": white * sigma_v,
            "horizontal_velocity_noise_sigma_m_s": velocity_h,
            "vertical_velocity_noise_sigma_m_s": velocity_h
            * float(sky["vertical_velocity_per_horizontal"]),
        }


@dataclass(frozen=True)
class SensorClass:
    """An IMU or barometer class: its model parameters in SI units, converted from its source."""

    name: str
    """Catalogue name (what an airframe's ``imu.sensor`` / ``baro.sensor`` says)."""
    description: str
    """The part and its operating mode."""
    source: str
    """Document and table the figures come from."""
    conditions: str
    """The source's conditions of the figures."""
    datasheet: dict[str, float]
    """The figures as the source gives them (its units in the keys)."""
    params: dict[str, float]
    """Model parameters (ImuParams / BaroParams fields), SI."""


@dataclass(frozen=True)
class SensorCatalogue:
    """Every class of ``catalogue.yaml``, by kind and name."""

    gnss_sky: dict[str, Any]
    """Shared GNSS assumptions (satellites, DOP, correlation times, delay)."""
    gnss_receivers: dict[str, GnssReceiverClass]
    """GNSS receiver classes by name."""
    imu_sensors: dict[str, SensorClass]
    """IMU classes by name."""
    baro_sensors: dict[str, SensorClass]
    """Barometer classes by name."""


def _sensor_class(name: str, entry: dict[str, Any], defaults: dict[str, float]) -> SensorClass:
    """A sensor class from its YAML entry: datasheet keys converted, SI keys as they are."""
    figures = {k: float(v) for k, v in entry.items() if k not in _TEXT_KEYS}
    params = dict(defaults)
    for key, value in figures.items():
        target, factor = _DATASHEET_UNITS.get(key, (key, 1.0))
        params[target] = value * factor
    return SensorClass(
        name=name,
        description=str(entry.get("description", "")).strip(),
        source=str(entry["source"]).strip(),
        conditions=str(entry.get("conditions", "")).strip(),
        datasheet=figures,
        params=params,
    )


@cache
def load_catalogue(path: Path = CATALOGUE_PATH) -> SensorCatalogue:
    """Read and convert the catalogue (cached: the file is package data)."""
    data = yaml.safe_load(path.read_text())
    sky = {k: v for k, v in data["gnss_sky"].items() if k not in ("description", "source")}
    receivers = {
        name: GnssReceiverClass(
            name=name,
            description=str(entry["description"]).strip(),
            source=str(entry["source"]).strip(),
            conditions=str(entry["conditions"]).strip(),
            horizontal_cep50_m=float(entry["horizontal_cep50_m"]),
            velocity_50_m_s=float(entry["velocity_50_m_s"]),
            vertical_r50_m=(
                None if entry.get("vertical_r50_m") is None else float(entry["vertical_r50_m"])
            ),
        )
        for name, entry in data["gnss_receivers"].items()
    }
    bias_process = {
        k: float(v)
        for k, v in data["imu_bias_process"].items()
        if k not in ("description", "source")
    }
    imu_defaults = {**bias_process, "turn_on_bias_scale": 1.0}
    imus = {
        name: _sensor_class(name, entry, imu_defaults)
        for name, entry in data["imu_sensors"].items()
    }
    baros = {
        name: _sensor_class(name, entry, {"drift_pa_s": 0.0})
        for name, entry in data["baro_sensors"].items()
    }
    return SensorCatalogue(sky, receivers, imus, baros)


def class_params(section: str, name: str) -> dict[str, Any]:
    """Model parameters of class ``name`` for airframe section ``gps``, ``imu`` or ``baro``.

    Raises:
        KeyError: for an unknown name; the message lists the known ones.
    """
    catalogue = load_catalogue()
    if section == "gps":
        table: dict[str, Any] = catalogue.gnss_receivers
    elif section == "imu":
        table = catalogue.imu_sensors
    elif section == "baro":
        table = catalogue.baro_sensors
    else:
        raise ValueError(f"no sensor classes for section {section!r}")
    if name not in table:
        raise KeyError(f"unknown {section} class {name!r} (known: {', '.join(sorted(table))})")
    entry = table[name]
    if isinstance(entry, GnssReceiverClass):
        return entry.gps_params(catalogue.gnss_sky)
    return dict(entry.params)
