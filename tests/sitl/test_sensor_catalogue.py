"""Sensor classes: every figure has a source, conversions to the models' units are right."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.sensors import catalogue
from sitl.sensors.baro import BaroParams
from sitl.sensors.gps import GpsParams
from sitl.sensors.imu import ImuParams


def test_cep50_and_r50_factors_are_the_gaussian_quantiles():
    """Half of a circular Gaussian's radii lie within 1.1774 sigma, half of |x| within 0.6745."""
    z = np.random.default_rng(0).standard_normal((1_000_000, 2))
    assert np.median(np.hypot(z[:, 0], z[:, 1])) == pytest.approx(catalogue.CEP50_PER_SIGMA, 2e-3)
    assert np.median(np.abs(z[:, 0])) == pytest.approx(catalogue.R50_PER_SIGMA, rel=2e-3)


def test_every_class_builds_its_model_and_names_its_source():
    """Each class yields a complete, valid parameter set and carries a source document."""
    cat = catalogue.load_catalogue()
    for name, receiver in cat.gnss_receivers.items():
        assert receiver.source and receiver.conditions, name
        GpsParams(**catalogue.class_params("gps", name))
    for name, imu in cat.imu_sensors.items():
        assert imu.source, name
        ImuParams(**catalogue.class_params("imu", name))
    for name, baro in cat.baro_sensors.items():
        assert baro.source, name
        BaroParams(**catalogue.class_params("baro", name))


def test_datasheet_units_are_converted_to_si():
    """ICM-42688-P: 2.8 mdeg/s/sqrt(Hz), 70 ug/sqrt(Hz), 0.5 deg/s, 20 mg; MS5611: 0.012 mbar."""
    imu = catalogue.class_params("imu", "icm42688p")
    assert imu["gyro_noise_density_rad_s_sqrt_hz"] == pytest.approx(0.0028 * math.pi / 180.0)
    assert imu["accel_noise_density_m_s2_sqrt_hz"] == pytest.approx(70e-6 * 9.80665)
    assert imu["gyro_turn_on_bias_sigma_rad_s"] == pytest.approx(0.5 * math.pi / 180.0)
    assert imu["accel_turn_on_bias_sigma_m_s2"] == pytest.approx(0.020 * 9.80665)
    assert catalogue.class_params("baro", "ms5611")["pressure_noise_pa"] == pytest.approx(1.2)


def test_receiver_accuracy_at_the_reference_geometry_is_the_datasheet_cep():
    """eph at HDOP_ref is CEP50 / 1.1774 for each receiver; RTK's vertical is R50 / 0.6745."""
    cat = catalogue.load_catalogue()
    for name, receiver in cat.gnss_receivers.items():
        params = GpsParams(**catalogue.class_params("gps", name))
        eph, epv = params.accuracy_m(np.array([params.satellites_reference]))
        assert eph[0] == pytest.approx(receiver.horizontal_cep50_m / 1.1774, rel=1e-4), name
        if receiver.vertical_r50_m is not None:
            assert epv[0] == pytest.approx(receiver.vertical_r50_m / 0.6745, rel=1e-4), name


def test_unknown_class_lists_the_known_ones():
    """An unknown name raises KeyError naming the known classes of that section."""
    with pytest.raises(KeyError, match=r"unknown baro class 'bmp999' \(known: ms5611, px4_gaz"):
        catalogue.class_params("baro", "bmp999")
