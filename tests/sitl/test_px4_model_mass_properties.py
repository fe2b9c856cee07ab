"""Mass, centre of mass, inertia and rotor hubs of the shipped airframes against PX4's models.

The oracle is PX4's own model files, their link inertials copied into this test (not read from
our YAML) and lumped here with the parallel-axis theorem written out:

- typhoon_h480: PX4/PX4-SITL_gazebo-classic models/typhoon_h480/typhoon_h480.sdf.jinja
  (commit 46aef29718495d2f668c1648f4c0b0f43b9d9671): base_link, four CGO3 gimbal links, two
  legs, the imu link and six rotors, each with its link pose composed with its inertial pose;
  motor plugins for motorNumber and turningDirection;
- x500: PX4/PX4-gazebo-models models/x500_base/model.sdf (commit
  008216ec29bd87a0226576f72d5c96c0bdf53ca8) for the links and models/x500/model.sdf (commit
  0f0e45da735515fdecc36442a7b57e7a68a1e686) for the motors;
- typhoon_h480_yuneec: the Typhoon's SDF table with every mass and link inertia scaled to
  Yuneec's published 1695 g (its YAML's documented assumption: 1.695 / 2.665).

What the loader gives (mass and inertia from the URDF, hubs from the rotor table) must equal it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.physics.rotors import Spin
from sitl.vehicles.multirotor import load_airframe

# (name, mass kg, centre of mass x y z m (SDF model frame), yaw of the inertia axes rad,
#  ixx iyy izz kg m^2); no SDF link here has products of inertia or roll/pitch.
_TYPHOON_ROTOR_I = (9.75e-07, 0.000273104, 0.000274004)
TYPHOON_SDF_LINKS = (
    ("base_link", 2.02, (0.001005, 0.0, -0.0090035), 0.0, (0.011, 0.015, 0.021)),
    ("cgo3_mount_link", 0.1, (-0.041, 0.0, -0.162), 0.0, (0.001, 0.001, 0.001)),
    ("cgo3_vertical_arm_link", 0.1, (-0.041, 0.0, -0.162), 0.0, (0.001, 0.001, 0.001)),
    ("cgo3_horizontal_arm_link", 0.1, (-0.041, 0.0, -0.081), 0.0, (0.001, 0.001, 0.001)),
    ("cgo3_camera_link", 0.1, (-0.041, 0.0, -0.162), 0.0, (0.001, 0.001, 0.001)),
    ("left_leg", 0.1, (0.0, -0.14314, -0.207252), 0.0, (0.001, 0.001, 0.001)),
    ("right_leg", 0.1, (0.0, 0.14314, -0.207252), 0.0, (0.001, 0.001, 0.001)),
    ("typhoon_h480/imu_link", 0.015, (0.0, 0.0, 0.0), 0.0, (1e-05, 1e-05, 1e-05)),
    ("rotor_0", 0.005, (-0.209396, 0.122762, 0.082219), 2.09439510239, _TYPHOON_ROTOR_I),
    ("rotor_1", 0.005, (0.211396, -0.119762, 0.082219), -2.09439510239, _TYPHOON_ROTOR_I),
    ("rotor_2", 0.005, (-0.209396, -0.122762, 0.082219), 2.09439510239, _TYPHOON_ROTOR_I),
    ("rotor_3", 0.005, (0.211396, 0.119762, 0.082219), 0.0, _TYPHOON_ROTOR_I),
    ("rotor_4", 0.005, (-0.00187896, 0.242705, 0.0822169), 0.0, _TYPHOON_ROTOR_I),
    ("rotor_5", 0.005, (-0.00187896, -0.242705, 0.0822169), -2.09439510239, _TYPHOON_ROTOR_I),
)
# Motor plugins of the Typhoon SDF: link -> (motorNumber = PX4 output, turningDirection).
TYPHOON_SDF_MOTORS = {
    "rotor_0": (5, "cw"),
    "rotor_1": (4, "ccw"),
    "rotor_2": (3, "ccw"),
    "rotor_3": (2, "cw"),
    "rotor_4": (1, "ccw"),
    "rotor_5": (0, "cw"),
}

_X500_ROTOR_I = (3.8464910483993325e-07, 2.6115851691700804e-05, 2.649858234714004e-05)
X500_SDF_LINKS = (
    ("base_link", 2.0, (0.0, 0.0, 0.0), 0.0, (0.02166666666666667, 0.02166666666666667, 0.04)),
    ("rotor_0", 0.016076923076923075, (0.174, -0.174, 0.06), 0.0, _X500_ROTOR_I),
    ("rotor_1", 0.016076923076923075, (-0.174, 0.174, 0.06), 0.0, _X500_ROTOR_I),
    ("rotor_2", 0.016076923076923075, (0.174, 0.174, 0.06), 0.0, _X500_ROTOR_I),
    ("rotor_3", 0.016076923076923075, (-0.174, -0.174, 0.06), 0.0, _X500_ROTOR_I),
)
X500_SDF_MOTORS = {
    "rotor_0": (0, "ccw"),
    "rotor_1": (1, "ccw"),
    "rotor_2": (2, "cw"),
    "rotor_3": (3, "cw"),
}

YUNEEC_TAKEOFF_MASS_KG = 1.695
"""Yuneec Typhoon H: take-off weight 1695 g with battery and camera (Yuneec specifications)."""

MODELS = {
    "typhoon_h480": (TYPHOON_SDF_LINKS, TYPHOON_SDF_MOTORS, 1.0),
    "typhoon_h480_yuneec": (TYPHOON_SDF_LINKS, TYPHOON_SDF_MOTORS, YUNEEC_TAKEOFF_MASS_KG / 2.665),
    "x500": (X500_SDF_LINKS, X500_SDF_MOTORS, 1.0),
}


def lump(links, scale: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Total mass, centre of mass and inertia about it of the links, masses times ``scale``."""
    mass = sum(scale * m for _, m, _, _, _ in links)
    com = sum(scale * m * np.array(p) for _, m, p, _, _ in links) / mass
    inertia = np.zeros((3, 3))
    for _, m, p, yaw, diag in links:
        c, s = math.cos(yaw), math.sin(yaw)
        rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        d = np.array(p) - com
        inertia += scale * (rz @ np.diag(diag) @ rz.T)  # the link's own inertia, turned
        inertia += scale * m * (d @ d * np.eye(3) - np.outer(d, d))  # Huygens-Steiner
    return mass, com, inertia


@pytest.mark.parametrize("name", sorted(MODELS))
def test_lumped_body_is_the_px4_model(name):
    """Mass and principal moments of the simulated body = the PX4 model's links lumped.

    The URDF rounds the moments to 6 significant digits (largest rel. error 2.1e-6, the
    Yuneec's iyy) and the x500's rotor masses to 8 (3.7e-9); the dropped product of inertia of
    the Typhoons (ixz) is under 5 % of the moments.
    """
    links, _, scale = MODELS[name]
    mass, _, inertia = lump(links, scale)
    spec = load_airframe(name)
    assert spec.mass_kg == pytest.approx(mass, rel=5.5e-9)
    assert spec.inertia_diag_kg_m2 == pytest.approx(np.diag(inertia), rel=3e-6)
    assert abs(inertia[0, 2]) < 0.05 * np.diag(inertia).min()
    assert abs(inertia[0, 1]) < 1e-12 and abs(inertia[1, 2]) < 1e-12


def test_the_typhoons_weigh_the_sdf_and_the_published_aircraft():
    """typhoon_h480 is the SDF's 2.665 kg; typhoon_h480_yuneec Yuneec's 1.695 kg, same shape.

    The Yuneec's YAML writes the scaled masses to 7 digits: its centre of mass is the SDF's
    within 8.7e-9 m, its moments the SDF's times 1.695 / 2.665 within 2.1e-6.
    """
    sdf_mass, sdf_com, sdf_inertia = lump(TYPHOON_SDF_LINKS, 1.0)
    assert sdf_mass == pytest.approx(2.665, abs=1e-12)
    assert load_airframe("typhoon_h480").mass_kg == pytest.approx(sdf_mass, abs=1e-9)
    yuneec = load_airframe("typhoon_h480_yuneec")
    assert yuneec.mass_kg == YUNEEC_TAKEOFF_MASS_KG
    ratio = np.array(yuneec.inertia_diag_kg_m2) / np.diag(sdf_inertia)
    assert ratio == pytest.approx(np.full(3, YUNEEC_TAKEOFF_MASS_KG / 2.665), rel=3e-6)
    assert yuneec.composite.center_of_mass_m == pytest.approx(sdf_com, abs=1.3e-8)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_rotor_hubs_and_spins_are_the_px4_models(name):
    """Output i is the SDF rotor with motorNumber i, at its link position seen from the CoM (FRD),
    spinning as its turningDirection says. The YAML rounds hubs to the micrometre (largest error
    0.37 um)."""
    links, motors, scale = MODELS[name]
    _, com, _ = lump(links, scale)
    position = {link: np.array(p) for link, _, p, _, _ in links}
    spec = load_airframe(name)
    assert len(spec.rotors) == len(motors)
    for link, (output, direction) in motors.items():
        rotor = spec.rotors[output]
        flu = position[link] - com
        assert rotor.position_frd_m == pytest.approx([flu[0], -flu[1], -flu[2]], abs=5.5e-7)
        assert rotor.spin is Spin(direction)
