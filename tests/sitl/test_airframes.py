"""Airframes as data: composite mass properties, rotor tables, PX4 sections, loader errors, and
the physics each airframe implies (hover trim, roll response to a torque step)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
import yaml
from sitl_test_helpers import actuator_message, hover_trim, make_world

from sitl.physics.rotors import Spin
from sitl.vehicles import multirotor
from sitl.vehicles.mass_properties import LinkInertial, composite_body, rotation_from_rpy
from sitl.vehicles.urdf import inspect_urdf

AIRFRAMES = ("typhoon_h480", "typhoon_h480_yuneec", "x500")


def links_from_yaml(name: str) -> list[LinkInertial]:
    """The mass_properties table read straight from the YAML (not through the loader)."""
    data = yaml.safe_load((multirotor.AIRFRAME_DIR / name / f"{name}.yaml").read_text())
    return [
        LinkInertial(
            row["name"],
            row["mass_kg"],
            tuple(row["position_m"]),
            tuple(row["rpy_rad"]),
            tuple(row["inertia_kg_m2"]),
        )
        for row in data["mass_properties"]["links"]
    ]


def test_composite_of_two_point_masses_and_a_rotated_rod():
    """Parallel-axis theorem and tensor rotation against hand-computed values."""
    a = LinkInertial("a", 1.0, (1.0, 0.0, 0.0), (0, 0, 0), (0, 0, 0, 0, 0, 0))
    b = LinkInertial("b", 3.0, (-1.0, 0.0, 0.0), (0, 0, 0), (0, 0, 0, 0, 0, 0))
    body = composite_body([a, b])
    assert body.mass_kg == 4.0
    assert body.center_of_mass_m == pytest.approx([-0.5, 0.0, 0.0])
    # 1 kg at 1.5 m and 3 kg at 0.5 m from the CoM: 2.25 + 0.75 = 3 kg m^2 about y and z.
    assert np.diag(body.inertia_kg_m2) == pytest.approx([0.0, 3.0, 3.0])
    rod = LinkInertial("rod", 1.0, (0, 0, 0), (0, 0, np.pi / 2), (0.0, 2.0, 2.0, 0, 0, 0))
    turned = composite_body([rod]).inertia_kg_m2
    assert np.diag(turned) == pytest.approx([2.0, 0.0, 2.0], abs=1e-12)  # axis now along y
    r = rotation_from_rpy((0.1, 0.2, 0.3))
    assert r @ r.T == pytest.approx(np.eye(3), abs=1e-12)


@pytest.mark.parametrize("name", AIRFRAMES)
def test_urdf_holds_the_composite_of_the_yaml_links(name):
    """The URDF's single body is recomputed from the YAML's link table: they cannot drift."""
    composite = composite_body(links_from_yaml(name))
    body = inspect_urdf(multirotor.AIRFRAME_DIR / name / f"{name}.urdf")
    assert body.mass_kg == pytest.approx(composite.mass_kg, rel=1e-6)
    assert body.inertia_diag_kg_m2 == pytest.approx(np.diag(composite.inertia_kg_m2), rel=1e-5)


@pytest.mark.parametrize("name", AIRFRAMES)
def test_rotor_hubs_are_the_rotor_links_seen_from_the_centre_of_mass(name):
    """Each rotor's FRD hub position = its SDF link position minus the composite CoM."""
    spec = multirotor.load_airframe(name)
    links = {link.name: link for link in links_from_yaml(name)}
    com = composite_body(list(links.values())).center_of_mass_m
    data = yaml.safe_load(spec.yaml_path.read_text())
    for row, rotor in zip(
        sorted(data["rotors"], key=lambda r: r["output"]), spec.rotors, strict=True
    ):
        link = links[row["rotor_link"]]
        flu = np.asarray(link.position_m) - com
        assert rotor.position_frd_m == pytest.approx([flu[0], -flu[1], -flu[2]], abs=2e-6)


@pytest.mark.parametrize(
    ("name", "autostart", "mav_type", "n_rotors", "hover_guess"),
    [
        ("typhoon_h480", 6011, 13, 6, None),
        ("typhoon_h480_yuneec", 6011, 13, 6, 0.70),
        ("x500", 4001, 2, 4, 0.60),
    ],
)
def test_px4_section_is_the_px4_airframe_file(name, autostart, mav_type, n_rotors, hover_guess):
    """SYS_AUTOSTART, MAV_TYPE and the CA_ROTOR geometry in output order; MPC_THR_HOVER where
    PX4's file sets it (4001_gz_x500: 0.60; 6011 leaves PX4's default) or the calibrated
    airframe needs its hover output within HTE_THR_RANGE of the guess (0.70)."""
    spec = multirotor.load_airframe(name)
    params = spec.px4_params
    assert params["SYS_AUTOSTART"] == autostart
    assert params["MAV_TYPE"] == mav_type
    assert params["CA_ROTOR_COUNT"] == n_rotors == len(spec.rotors)
    assert params.get("MPC_THR_HOVER") == hover_guess
    for i, rotor in enumerate(spec.rotors):
        assert np.sign(params[f"CA_ROTOR{i}_KM"]) == (1 if rotor.spin is Spin.CCW else -1)
        bearing_px4 = np.arctan2(params[f"CA_ROTOR{i}_PY"], params[f"CA_ROTOR{i}_PX"])
        bearing_sim = np.arctan2(rotor.position_frd_m[1], rotor.position_frd_m[0])
        assert abs(np.angle(np.exp(1j * (bearing_px4 - bearing_sim)))) < np.radians(15.0)


# -- loader errors ----------------------------------------------------------------------------


@pytest.fixture
def x500_copy(tmp_path, monkeypatch):
    """A writable copy of the shipped airframes, used instead of the package folder."""
    for name in AIRFRAMES:
        shutil.copytree(multirotor.AIRFRAME_DIR / name, tmp_path / name)
    monkeypatch.setattr(multirotor, "AIRFRAME_DIR", tmp_path)
    return tmp_path / "x500" / "x500.yaml"


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("urdf: x500.urdf\n", "urdf: x500.urdf\nwings: 2\n", r"unknown sections \['wings'\]"),
        ("  drag_area_m2:", "  drag_areas_m2:", r"section 'fuselage'.*drag_area_m2.*drag_areas"),
        ("spin: ccw}    # front right", "spin: ccw, tilt_deg: 3}", r"rotors\[0\]: unknown keys"),
        ("x_m: 0.174, y_m: 0.174,", "x_m: 0.184, y_m: 0.174,", r"rotors\[0\].*disagrees with link"),
        (
            "    MAV_TYPE: 2 ",
            "    MAV_TYPE: 13 ",
            r"px4.params.MAV_TYPE = 13, a 4-rotor frame is MAV_TYPE 2",
        ),
        ("    CA_ROTOR_COUNT: 4", "    CA_ROTOR_COUNT: 6", r"CA_ROTOR_COUNT = 6 but .* 4 rotors"),
        (
            "    CA_ROTOR2_KM: -0.05",
            "    CA_ROTOR2_KM: 0.05",
            r"CA_ROTOR2_KM = 0.05 does not match",
        ),
        ("    CA_ROTOR1_PY: -0.20", "    CA_ROTOR1_PY: 0.20", r"CA_ROTOR1_PY = 0.2 puts rotor 1"),
        ("    CA_ROTOR3_KM: -0.05\n", "", r"missing CA_ROTOR3_KM"),
        ("    NAV_DLL_ACT: 2", "    nav_dll_act: 2", r"'nav_dll_act' is not a PX4 parameter"),
        ("    NAV_DLL_ACT: 2", "    NAV_DLL_ACT: two", r"NAV_DLL_ACT: 'two' is not a finite"),
        ("name: rotor_3, mass_kg", "name: rotor_3, mas_kg", r"links\[4\]'.*missing.*mass_kg"),
        ("mass_kg: 2.0,", "mass_kg: 2.5,", r"the URDF body .* not the composite"),
        (
            "  receiver: neo_m9n",
            "  receiver: neo_m10",
            r"section 'gps': receiver: unknown gps class 'neo_m10' \(known: neo_m8n, .*zed_f9p",
        ),
        (
            "  sensor: icm42688p",
            "  sensor: bmi999",
            r"section 'imu': sensor: unknown imu class 'bmi999' \(known: icm42688p, px4_gaz",
        ),
        (
            "  sensor: ms5611",
            "  sensor: ms5611\n  drift_pa: 1",
            r"section 'baro'.*unknown \['drift_pa'\]",
        ),
    ],
)
def test_wrong_or_missing_field_names_file_and_field(x500_copy, old, new, message):
    """Every new section fails at load with the file and the field named."""
    text = x500_copy.read_text()
    assert old in text, old
    x500_copy.write_text(text.replace(old, new, 1))
    with pytest.raises(ValueError, match=r"x500\.(yaml|urdf).*" + message):
        multirotor.load_airframe("x500")


def test_a_sensor_class_with_explicit_fields_overriding_it(x500_copy):
    """A section naming a class takes the class's parameters; a field written next to it wins."""
    text = x500_copy.read_text()
    x500_copy.write_text(
        text.replace("  receiver: neo_m9n", "  receiver: zed_f9p_rtk\n  delay_ms: 60")
    )
    gps = multirotor.load_airframe("x500").gps
    assert gps.delay_ms == 60.0
    # ZED-F9P RTK: 0.01 m CEP50 -> eph at the reference geometry 0.01 / 1.1774 m per axis.
    eph, _ = gps.accuracy_m(np.array([gps.satellites_reference]))
    assert eph[0] == pytest.approx(0.01 / 1.1774, rel=1e-3)


def test_missing_px4_section_is_named(x500_copy):
    """A YAML without its px4 section is rejected naming the section."""
    text = x500_copy.read_text()
    x500_copy.write_text(text[: text.index("\npx4:")] + "\n")
    with pytest.raises(ValueError, match=r"x500\.yaml: missing sections \[.*'px4'\]"):
        multirotor.load_airframe("x500")


def test_an_airframe_is_a_folder(tmp_path):
    """A user's airframe is a folder given by path: ``<dir>/<name>/<name>.yaml`` + its URDF."""
    folder = tmp_path / "my_quad"
    folder.mkdir()
    shutil.copy(multirotor.AIRFRAME_DIR / "x500" / "x500.urdf", folder / "x500.urdf")
    text = (multirotor.AIRFRAME_DIR / "x500" / "x500.yaml").read_text()
    (folder / "my_quad.yaml").write_text(
        text.replace("max_speed_rad_s: 1000.0", "max_speed_rad_s: 1100.0")
    )
    spec = multirotor.load_airframe(str(folder))
    assert spec.name == "my_quad"
    assert spec.motor.max_speed_rad_s == 1100.0
    with make_world(airframe=str(folder), spawn_altitude_m=5.0) as world:
        assert world.airframe.name == "my_quad"
    with make_world(n_vehicles=2, airframe=(folder, "x500"), spawn_altitude_m=5.0) as world:
        assert [spec.name for spec in world.airframes] == ["my_quad", "x500"]
    with pytest.raises(ValueError, match=r"has no empty\.yaml"):
        (tmp_path / "empty").mkdir()
        multirotor.load_airframe(tmp_path / "empty")


# -- physics per airframe ---------------------------------------------------------------------


@pytest.mark.parametrize("name", AIRFRAMES)
def test_hover_trim_holds_altitude_and_attitude(name):
    """Thrust = weight and zero torque about the composite CoM: the body neither climbs nor turns.

    Equal rotor speeds would not do for the Typhoon: its centre of mass is 5.4 mm behind the
    rotors' centre, so the trim runs the rear rotors faster.
    """
    with make_world(airframe=name, spawn_altitude_m=20.0) as world:
        u = hover_trim(world.airframe)
        command = [actuator_message(list(u))]
        for _ in range(150):  # 0.3 s: rotors settle (time constants 12.5 / 25 ms)
            world.step(command)
        v0 = world.truth.velocity_enu_m_s[0, 2]
        for _ in range(1000):
            world.step(command)
        truth = world.truth
        assert abs(truth.velocity_enu_m_s[0, 2] - v0) < 0.02
        assert np.linalg.norm(truth.angular_velocity_body_frd_rad_s[0]) < 0.01
        assert truth.tilt_rad[0] < 0.01
    if name.startswith("typhoon_h480"):
        rear = [i for i, r in enumerate(world.airframe.rotors) if r.position_frd_m[0] < -0.1]
        front = [i for i, r in enumerate(world.airframe.rotors) if r.position_frd_m[0] > 0.1]
        assert u[rear].mean() > u[front].mean()


@pytest.mark.parametrize("name", AIRFRAMES)
def test_roll_step_accelerates_as_torque_over_composite_inertia(name):
    """A roll torque step gives d(omega)/dt = tau / I_xx with the composite inertia of the links.

    The prediction integrates the true rotor speeds through the layout; it uses the inertia
    recomputed from the YAML's links, so a URDF with 1/3 of it would fail by a factor of three.
    """
    with make_world(airframe=name, spawn_altitude_m=20.0) as world:
        spec = world.airframe
        k_f = spec.motor.thrust_coefficient_n_s2_rad2
        y = np.array([r.position_frd_m[1] for r in spec.rotors])
        u = hover_trim(spec)
        for _ in range(150):
            world.step([actuator_message(list(u))])
        inertia = composite_body(links_from_yaml(name)).inertia_kg_m2[0, 0]
        rate0 = world.truth.angular_velocity_body_frd_rad_s[0, 0]
        step = [actuator_message(list(u + 0.03 * (y < 0)))]  # left rotors faster: roll right
        predicted = rate0
        for _ in range(50):  # 0.1 s
            w = world.truth.rotor_speed_rad_s[0]
            predicted += float(-y @ (k_f * w**2)) / inertia / world.config.physics_hz
            world.step(step)
        rate = world.truth.angular_velocity_body_frd_rad_s[0, 0]
    assert predicted > 0.2
    assert rate == pytest.approx(predicted, rel=0.03)


def test_mixed_airframes_fly_as_if_alone():
    """Typhoon, x500, Typhoon in one world: each vehicle moves exactly as alone with its airframe,
    and sensors come one message per vehicle in vehicle order."""
    names = ("typhoon_h480", "x500", "typhoon_h480")
    commands = []
    for name in names:
        u = hover_trim(multirotor.load_airframe(name))
        commands.append(actuator_message(list(u + 0.02 * (np.arange(len(u)) == 0))))
    with make_world(n_vehicles=3, spacing_m=10.0, spawn_altitude_m=10.0, airframe=names) as world:
        assert [spec.name for spec in world.airframes] == list(names)
        sensors = gps = None
        for _ in range(250):
            world.step(commands)
            s, g = world.poll_sensors()
            sensors, gps = s or sensors, g or gps
        truth = world.truth
        assert len(sensors) == len(gps) == 3
        assert truth.rotor_speed_rad_s.shape == (3, 6)
        assert np.all(truth.rotor_speed_rad_s[1, 4:] == 0.0)  # the quad has four rotors
        for i, (name, command) in enumerate(zip(names, commands, strict=True)):
            with make_world(airframe=name, spawn_altitude_m=10.0) as alone:
                for _ in range(250):
                    alone.step([command])
                offset = np.array([10.0 * i, 0.0, 0.0])
                assert truth.position_enu_m[i] - offset == pytest.approx(
                    alone.truth.position_enu_m[0], abs=1e-9
                )
                assert truth.electrical_power_w[i] == pytest.approx(
                    alone.truth.electrical_power_w[0], rel=1e-12
                )
        # Sensors follow each vehicle: the barometer altitude of vehicle i tracks its own height.
        heights = truth.position_enu_m[:, 2] + 488.0
        assert [m.pressure_alt for m in sensors] == pytest.approx(heights, abs=1.0)


def test_airframe_list_must_match_the_vehicle_count():
    """One airframe for all, or one per vehicle; an unknown one is named."""
    from sitl.world import WorldConfig

    assert WorldConfig(n_vehicles=2, airframe=("x500",)).airframes == ("x500", "x500")
    with pytest.raises(ValueError, match="2 names for 3 vehicles"):
        WorldConfig(n_vehicles=3, airframe=("x500", "typhoon_h480"))
    with pytest.raises(ValueError, match="unknown airframe 'x5000'"):
        WorldConfig(n_vehicles=2, airframe=("x500", "x5000"))
