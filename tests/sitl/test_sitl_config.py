"""WorldConfig validation and airframe loading errors."""

from __future__ import annotations

import shutil

import pytest
from pymavlink.dialects.v20 import common as mavlink2
from sitl_test_helpers import make_world

from sitl.vehicles import multirotor
from sitl.world import World, WorldConfig


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"imu_hz": 300.0}, "imu_hz=300 Hz does not divide physics_hz=500 Hz"),
        ({"gps_hz": 7.0}, "gps_hz=7 Hz does not divide"),
        ({"physics_hz": 400.0}, "imu_hz=250 Hz does not divide physics_hz=400 Hz"),
        ({"baro_hz": 0.0}, "baro_hz must be positive"),
        ({"mag_hz": -5.0}, "mag_hz must be positive"),
        ({"physics_hz": 0.0}, "physics_hz must be positive"),
        ({"imu_hz": 1000.0}, "does not divide"),
        ({"mag_hz": 500.0}, "exceeds imu_hz"),
        ({"n_vehicles": 0}, "n_vehicles must be >= 1"),
        ({"n_vehicles": 2, "spacing_m": 0.0}, "spacing_m must be positive"),
        ({"spawn_altitude_m": -1.0}, "spawn_altitude_m must be positive"),
        ({"origin_lat_deg": 91.0}, "origin_lat_deg"),
    ],
)
def test_invalid_config_is_rejected_with_the_reason(overrides, message):
    """Each invalid configuration raises ValueError naming what is wrong."""
    with pytest.raises(ValueError, match=message):
        WorldConfig(**overrides)


def test_unknown_airframe_lists_the_available_ones():
    """An unknown airframe name is rejected with the list of known airframes."""
    with pytest.raises(ValueError, match=r"unknown airframe 'x600': neither a folder nor .*x500"):
        WorldConfig(airframe="x600")


def test_spawn_below_resting_height_is_rejected():
    """A spawn altitude inside the ground is an error, not a bounce."""
    with pytest.raises(ValueError, match="below the resting height"):
        make_world(spawn_altitude_m=0.1)


def test_actuator_list_length_must_match():
    """step() wants one entry per vehicle."""
    with make_world(n_vehicles=2) as world:
        msg = mavlink2.MAVLink_hil_actuator_controls_message(0, [0.0] * 16, 0, 0)
        with pytest.raises(ValueError, match="expected 2 actuator entries"):
            world.step([msg])


@pytest.fixture
def airframe_copy(tmp_path, monkeypatch):
    """A writable copy of the shipped airframes, used instead of the package folder."""
    src = multirotor.AIRFRAME_DIR / "typhoon_h480"
    dst = tmp_path / "typhoon_h480"
    shutil.copytree(src, dst)
    monkeypatch.setattr(multirotor, "AIRFRAME_DIR", tmp_path)
    return dst


def test_broken_yaml_names_the_file(airframe_copy):
    """Invalid YAML is reported with the file's path."""
    (airframe_copy / "typhoon_h480.yaml").write_text("motor: [unclosed\n")
    with pytest.raises(ValueError, match=r"typhoon_h480\.yaml: not valid YAML"):
        multirotor.load_airframe("typhoon_h480")


def test_missing_yaml_key_names_the_file_and_section(airframe_copy):
    """A missing parameter is reported with the file, the section and the key."""
    path = airframe_copy / "typhoon_h480.yaml"
    path.write_text(path.read_text().replace("  max_speed_rad_s: 1500.0", ""))
    with pytest.raises(ValueError, match=r"typhoon_h480\.yaml: section 'motor'.*max_speed_rad_s"):
        multirotor.load_airframe("typhoon_h480")


def test_broken_urdf_names_the_file(airframe_copy):
    """A URDF that is not XML is reported with the file's path; so is a missing one."""
    urdf = airframe_copy / "typhoon_h480.urdf"
    urdf.write_text("<robot><link name='base_link'>")
    with pytest.raises(ValueError, match=r"typhoon_h480\.urdf: not valid XML"):
        World(WorldConfig())
    urdf.unlink()
    with pytest.raises(ValueError, match=r"typhoon_h480\.urdf: URDF file not found"):
        multirotor.load_airframe("typhoon_h480")


def test_urdf_with_offset_inertial_is_rejected(airframe_copy):
    """The URDF's inertial origin must be the CoM: rotor positions are relative to it."""
    urdf = airframe_copy / "typhoon_h480.urdf"
    urdf.write_text(
        urdf.read_text().replace(
            '<origin xyz="0 0 0" rpy="0 0 0"/>\n      <mass',
            '<origin xyz="0.01 0 0"/>\n      <mass',
        )
    )
    with pytest.raises(ValueError, match="inertial origin must be the link origin"):
        multirotor.load_airframe("typhoon_h480")


def test_shipped_airframe_facts():
    """The Typhoon H480 is loaded with the PX4 numbers and a hover command near 0.48."""
    spec = multirotor.load_airframe("typhoon_h480")
    assert spec.mass_kg == pytest.approx(2.665)
    # Composite of the SDF's links (was base_link's 0.011, 0.015, 0.021: 2.4-3.2x too low).
    assert spec.inertia_diag_kg_m2 == pytest.approx((0.0354, 0.0359, 0.0351), abs=1e-4)
    # Skids 0.207252 m below base_link, whose origin is 0.042728 m above the centre of mass.
    assert spec.ground_clearance_m == pytest.approx(0.207252 - 0.042728 + 0.012209, abs=1e-6)
    assert [r.output for r in spec.rotors] == list(range(6))
    assert [r.spin.value for r in spec.rotors] == ["cw", "ccw", "cw", "ccw", "ccw", "cw"]
    assert spec.motor.max_speed_rad_s == 1500.0
    assert spec.hover_command == pytest.approx(0.4760, abs=1e-4)
