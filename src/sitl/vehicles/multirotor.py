"""Multirotor airframes as data: ``vehicles/<name>/<name>.yaml`` + ``<name>.urdf``.

A multirotor is its rotor layout table plus motor, drag and sensor parameters (the YAML), and one
rigid body with collision shapes (the URDF, which owns mass and inertia).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
import yaml

from sitl.physics.drag import FuselageDrag, LevelFlight, level_flight_speed_m_s
from sitl.physics.earth import GRAVITY_M_S2
from sitl.physics.rotors import MotorParams, RotorSpec, Spin
from sitl.power.propulsion import load_power_spec
from sitl.sensors.baro import BaroParams
from sitl.sensors.camera import CameraSpec
from sitl.sensors.catalogue import class_params
from sitl.sensors.gps import GpsParams
from sitl.sensors.imu import ImuParams
from sitl.sensors.mag import MagParams
from sitl.sensors.rangefinder import MODELS, RangefinderSpec, rangefinder_from_model
from sitl.vehicles.mass_properties import CompositeBody, LinkInertial, composite_body
from sitl.vehicles.urdf import UrdfBody, inspect_urdf

AIRFRAME_DIR = Path(__file__).resolve().parent
"""Folder holding one sub-folder per airframe."""

TOP_LEVEL_KEYS = frozenset(
    {
        "description",
        "source",
        "urdf",
        "power",
        "mass_properties",
        "motor",
        "fuselage",
        "rotors",
        "imu",
        "mag",
        "baro",
        "gps",
        "px4",
    }
)
"""Every key an airframe YAML must have."""
OPTIONAL_KEYS = frozenset({"rangefinders", "camera", "kinematics"})
"""Keys an airframe YAML may have (absent: the airframe has none of that equipment)."""

MAV_TYPE_OF_ROTOR_COUNT = {4: 2, 6: 13, 8: 14}
"""MAVLink MAV_TYPE of a multirotor with that many rotors (QUADROTOR, HEXAROTOR, OCTOROTOR)."""

_PX4_PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")

_ROTOR_KEYS = frozenset({"output", "x_m", "y_m", "z_m", "spin", "rotor_link"})

_INERTIA_REL_TOL = 1e-4
_ROTOR_POSITION_TOL_M = 5e-6
_SIDE_TOL_M = 0.02


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
    links: tuple[LinkInertial, ...]
    """The source model's links, whose composite the URDF body is (``mass_properties``)."""
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
    px4_params: Mapping[str, int | float]
    """PX4 parameters the airframe sets (PX4's airframe file), name -> value, read-only."""
    rangefinders: tuple[RangefinderSpec, ...] = ()
    """Ultrasonic rangefinders and their mounts (the YAML's ``rangefinders``); () for none."""
    camera: CameraSpec | None = None
    """The airframe's camera (the YAML's optional ``camera`` section); None: no camera."""

    @property
    def extent_m(self) -> float:
        """Radius of the body around the centre of mass, m.

        The farthest rotor hub or the ground contact, whichever is farther: a sensor mounted
        farther out is outside the body.
        """
        hubs = max(float(np.linalg.norm(r.position_frd_m)) for r in self.rotors)
        return max(hubs, self.ground_clearance_m)

    def check_mount(self, camera: CameraSpec, where: str = "camera") -> None:
        """Raise ValueError naming ``<where>.position_frd_m`` if the camera is outside the body."""
        distance = float(np.linalg.norm(camera.position_frd_m))
        if distance > self.extent_m:
            raise ValueError(
                f"{where}.position_frd_m {camera.position_frd_m} m is {distance:.3f} m from the "
                f"centre of mass of {self.name}, outside its body (extent {self.extent_m:.3f} m)"
            )

    @property
    def hover_speed_rad_s(self) -> float:
        """Rotor speed at which all rotors together carry the weight, rad/s."""
        k_f = self.motor.thrust_coefficient_n_s2_rad2
        return float(np.sqrt(self.mass_kg * GRAVITY_M_S2 / (len(self.rotors) * k_f)))

    @property
    def hover_command(self) -> float:
        """Normalised motor command of hover, ``hover_speed_rad_s / max_speed_rad_s``."""
        return self.hover_speed_rad_s / self.motor.max_speed_rad_s

    def level_flight(self, tilt_rad: float) -> LevelFlight:
        """Steady level flight at a fixed tilt (closed form of the airframe's drag model)."""
        return level_flight_speed_m_s(
            tilt_rad,
            self.mass_kg,
            len(self.rotors),
            self.motor.thrust_coefficient_n_s2_rad2,
            self.motor.rotor_drag_coefficient_n_s_m_rad,
            self.fuselage,
        )

    @property
    def composite(self) -> CompositeBody:
        """Composite mass, centre of mass and inertia of ``links`` (source model frame)."""
        return composite_body(self.links)


def available_airframes() -> list[str]:
    """Names of the airframes shipped in ``sitl/vehicles``."""
    return sorted(
        d.name for d in AIRFRAME_DIR.iterdir() if d.is_dir() and (d / f"{d.name}.yaml").is_file()
    )


def airframe_yaml_path(name_or_folder: str | Path) -> Path:
    """The YAML of a shipped airframe (by name) or of a user's airframe folder (by path).

    A folder ``.../<name>/`` must hold ``<name>.yaml`` (and the URDF it names).

    Raises:
        ValueError: for an unknown name (listing the known ones) or a folder without its YAML.
    """
    text = str(name_or_folder)
    if text in available_airframes():
        return AIRFRAME_DIR / text / f"{text}.yaml"
    folder = Path(text).expanduser()
    if folder.is_dir():
        yaml_path = folder.resolve() / f"{folder.resolve().name}.yaml"
        if not yaml_path.is_file():
            raise ValueError(f"airframe folder {folder} has no {yaml_path.name}")
        return yaml_path
    raise ValueError(
        f"unknown airframe {text!r}: neither a folder nor one of {', '.join(available_airframes())}"
    )


def _build(cls: type, data: Any, section: str, path: Path) -> Any:
    """Construct dataclass ``cls`` from a YAML mapping, with errors that name file and section."""
    if not isinstance(data, dict):
        raise ValueError(f"{path}: section '{section}' must be a mapping")
    fields = dataclasses.fields(cls)
    names = {f.name for f in fields}
    required = {
        f.name
        for f in fields
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    }
    values = {k: v for k, v in data.items() if k not in ("description", "source")}
    unknown = sorted(set(values) - names)
    missing = sorted(required - set(values))
    if unknown or missing:
        raise ValueError(f"{path}: section '{section}': missing keys {missing}, unknown {unknown}")
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: section '{section}': {exc}") from exc


CLASS_KEYS = {"gps": "receiver", "imu": "sensor", "baro": "sensor"}
"""Key naming a catalogue class (sitl/sensors/catalogue.yaml) in each sensor section."""


def _sensor_section(cls: type, data: Any, section: str, path: Path) -> Any:
    """A sensor section built from its catalogue class, if it names one, and its own fields.

    ``receiver:`` (gps) or ``sensor:`` (imu, baro) names a class of sitl/sensors/catalogue.yaml;
    the section's explicit fields override the class's. Without a class every field is given.
    """
    if not isinstance(data, dict):
        raise ValueError(f"{path}: section '{section}' must be a mapping")
    key = CLASS_KEYS[section]
    if key not in data:
        return _build(cls, data, section, path)
    try:
        base = class_params(section, str(data[key]))
    except KeyError as exc:
        raise ValueError(f"{path}: section '{section}': {key}: {exc.args[0]}") from exc
    overrides = {k: v for k, v in data.items() if k != key}
    return _build(cls, {**base, **overrides}, section, path)


def _links(data: Any, path: Path) -> tuple[LinkInertial, ...]:
    if not isinstance(data, dict) or not isinstance(data.get("links"), list) or not data["links"]:
        raise ValueError(f"{path}: section 'mass_properties' needs a non-empty 'links' list")
    links = []
    for i, row in enumerate(data["links"]):
        link = _build(LinkInertial, row, f"mass_properties.links[{i}]", path)
        try:
            links.append(
                LinkInertial(
                    name=str(link.name),
                    mass_kg=float(link.mass_kg),
                    position_m=tuple(float(v) for v in link.position_m),
                    rpy_rad=tuple(float(v) for v in link.rpy_rad),
                    inertia_kg_m2=tuple(float(v) for v in link.inertia_kg_m2),
                )
            )
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: mass_properties.links[{i}]: {exc}") from exc
    return tuple(links)


def _rotors(data: Any, links: tuple[LinkInertial, ...], path: Path) -> tuple[RotorSpec, ...]:
    if not isinstance(data, list) or not data:
        raise ValueError(f"{path}: 'rotors' must be a non-empty list")
    com = composite_body(links).center_of_mass_m
    by_name = {link.name: link for link in links}
    rotors = []
    for i, row in enumerate(data):
        where = f"{path}: rotors[{i}]"
        if not isinstance(row, dict):
            raise ValueError(f"{where} must be a mapping")
        unknown = sorted(set(row) - _ROTOR_KEYS)
        if unknown:
            raise ValueError(f"{where}: unknown keys {unknown} (known: {sorted(_ROTOR_KEYS)})")
        try:
            rotor = RotorSpec(
                output=int(row["output"]),
                position_frd_m=(float(row["x_m"]), float(row["y_m"]), float(row["z_m"])),
                spin=Spin(str(row["spin"]).lower()),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(
                f"{where} needs output, x_m, y_m, z_m and spin (cw|ccw): {exc!r}"
            ) from exc
        if "rotor_link" in row:
            link = by_name.get(str(row["rotor_link"]))
            if link is None:
                raise ValueError(f"{where}: rotor_link {row['rotor_link']!r} is not a listed link")
            # Hub = link position minus the composite centre of mass, model FLU -> body FRD.
            expected = (np.asarray(link.position_m) - com) * np.array([1.0, -1.0, -1.0])
            if np.max(np.abs(expected - rotor.position_frd_m)) > _ROTOR_POSITION_TOL_M:
                raise ValueError(
                    f"{where}: hub position {rotor.position_frd_m} m (FRD, from the centre of "
                    f"mass) disagrees with link {link.name}: {tuple(np.round(expected, 6))} m"
                )
        rotors.append(rotor)
    rotors.sort(key=lambda r: r.output)
    if [r.output for r in rotors] != list(range(len(rotors))):
        raise ValueError(f"{path}: rotor outputs must be 0..{len(rotors) - 1}, each once")
    if len(rotors) > 16:
        raise ValueError(f"{path}: HIL_ACTUATOR_CONTROLS carries at most 16 outputs")
    return tuple(rotors)


def _px4_params(data: Any, rotors: tuple[RotorSpec, ...], path: Path) -> Mapping[str, int | float]:
    """The ``px4.params`` mapping, checked: PX4 names, numbers, and the frame they describe."""
    if not isinstance(data, dict) or set(data) - {"description", "source", "params"}:
        raise ValueError(f"{path}: section 'px4' must hold description, source and params only")
    params = data.get("params")
    if not isinstance(params, dict) or not params:
        raise ValueError(f"{path}: section 'px4' needs a non-empty 'params' mapping")
    for name, value in params.items():
        if not isinstance(name, str) or not _PX4_PARAM_NAME.match(name):
            raise ValueError(f"{path}: px4.params: {name!r} is not a PX4 parameter name")
        if isinstance(value, bool) or not isinstance(value, int | float) or not np.isfinite(value):
            raise ValueError(f"{path}: px4.params.{name}: {value!r} is not a finite number")
    for name in ("SYS_AUTOSTART", "MAV_TYPE", "CA_ROTOR_COUNT"):
        if name not in params:
            raise ValueError(f"{path}: px4.params: missing {name}")
    n_rotors = len(rotors)
    if params["CA_ROTOR_COUNT"] != n_rotors:
        raise ValueError(
            f"{path}: px4.params.CA_ROTOR_COUNT = {params['CA_ROTOR_COUNT']} but the rotor table "
            f"has {n_rotors} rotors"
        )
    expected_type = MAV_TYPE_OF_ROTOR_COUNT.get(n_rotors)
    if expected_type is not None and params["MAV_TYPE"] != expected_type:
        raise ValueError(
            f"{path}: px4.params.MAV_TYPE = {params['MAV_TYPE']}, a {n_rotors}-rotor frame is "
            f"MAV_TYPE {expected_type}"
        )
    for i, rotor in enumerate(rotors):
        for axis in ("PX", "PY", "KM"):
            if f"CA_ROTOR{i}_{axis}" not in params:
                raise ValueError(f"{path}: px4.params: missing CA_ROTOR{i}_{axis}")
        # PX4's geometry must describe the simulated one: same quadrant, same spin (KM > 0: CCW).
        for axis, coordinate in (("PX", rotor.position_frd_m[0]), ("PY", rotor.position_frd_m[1])):
            value = params[f"CA_ROTOR{i}_{axis}"]
            if (
                abs(coordinate) > _SIDE_TOL_M
                and abs(value) > _SIDE_TOL_M
                and (np.sign(value) != np.sign(coordinate))
            ):
                raise ValueError(
                    f"{path}: px4.params.CA_ROTOR{i}_{axis} = {value} puts rotor {i} on the other "
                    f"side from the rotor table ({coordinate:+.3f} m)"
                )
        if np.sign(params[f"CA_ROTOR{i}_KM"]) != (1.0 if rotor.spin is Spin.CCW else -1.0):
            raise ValueError(
                f"{path}: px4.params.CA_ROTOR{i}_KM = {params[f'CA_ROTOR{i}_KM']} does not match "
                f"spin {rotor.spin.value} of output {i} (PX4: positive for CCW)"
            )
    return MappingProxyType(dict(params))


def _rangefinders(data: Any, extent_m: float, path: Path) -> tuple[RangefinderSpec, ...]:
    """The ``rangefinders`` section: section-wide model and numbers, then one row per sensor.

    Errors name the file, the sensor (its index in ``sensors``) and the field.
    """
    if data is None:
        return ()
    if not isinstance(data, dict) or not isinstance(data.get("sensors"), list):
        raise ValueError(f"{path}: section 'rangefinders' needs a 'sensors' list")
    shared = {k: v for k, v in data.items() if k not in ("description", "source", "sensors")}
    specs: list[RangefinderSpec] = []
    for i, row in enumerate(data["sensors"]):
        where = f"{path}: rangefinders.sensors[{i}]"
        if not isinstance(row, dict):
            raise ValueError(f"{where} must be a mapping")
        values = {**shared, **row}
        model = str(values.pop("model", "hc_sr04"))
        if model not in MODELS:
            raise ValueError(f"{where}.model: {model!r} is not one of {sorted(MODELS)}")
        try:
            position = tuple(float(values.pop(k)) for k in ("x_m", "y_m", "z_m"))
            sensor_id = values.pop("id")
            orientation = values.pop("orientation")
        except KeyError as exc:
            raise ValueError(
                f"{where} needs id, orientation, x_m, y_m and z_m: missing {exc}"
            ) from exc
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where}: x_m, y_m, z_m must be numbers ({exc})") from exc
        try:
            spec = rangefinder_from_model(model, sensor_id, orientation, position, **values)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{where} (id {sensor_id}): {exc}") from exc
        distance = float(np.linalg.norm(position))
        if distance > extent_m:
            raise ValueError(
                f"{where} (id {sensor_id}): position_frd_m {position} is {distance:.3f} m from the "
                f"centre of mass, outside the airframe (extent {extent_m:.3f} m)"
            )
        if any(s.id == spec.id for s in specs):
            raise ValueError(f"{where}: id {spec.id} is used twice (ids must be distinct)")
        specs.append(spec)
    return tuple(specs)


def _check_urdf_against_links(body: UrdfBody, links: tuple[LinkInertial, ...], path: Path) -> None:
    """The URDF body must be the composite of the YAML's links (mass and diagonal inertia)."""
    composite = composite_body(links)
    urdf_inertia = np.array(body.inertia_diag_kg_m2)
    diag = np.diag(composite.inertia_kg_m2)
    if abs(body.mass_kg - composite.mass_kg) > _INERTIA_REL_TOL * composite.mass_kg or np.any(
        np.abs(urdf_inertia - diag) > _INERTIA_REL_TOL * diag
    ):
        raise ValueError(
            f"{path}: the URDF body (mass {body.mass_kg} kg, inertia {tuple(urdf_inertia)} kg m^2) "
            f"is not the composite of the mass_properties links (mass {composite.mass_kg:.6g} kg, "
            f"inertia {tuple(float(f'{v:.6g}') for v in diag)} kg m^2)"
        )
    products = composite.inertia_kg_m2 - np.diag(diag)
    if np.max(np.abs(products)) > 0.1 * diag.min():
        raise ValueError(
            f"{path}: the composite inertia has products of inertia above 10 % of its moments; "
            "the single-link URDF keeps only the diagonal"
        )


def load_airframe(name: str | Path) -> MultirotorSpec:
    """Load an airframe: a name of ``sitl/vehicles/<name>/`` or a path to a folder like it.

    Raises:
        ValueError: for an unknown name (listing the known ones), or a broken YAML/URDF (naming the
            file and the field).
    """
    yaml_path = airframe_yaml_path(name)
    try:
        data = yaml.safe_load(yaml_path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{yaml_path}: not valid YAML ({exc})") from exc
    if not isinstance(data, dict):
        raise ValueError(f"{yaml_path}: expected a mapping at the top level")
    unknown = sorted(set(data) - TOP_LEVEL_KEYS - OPTIONAL_KEYS)
    missing = sorted(TOP_LEVEL_KEYS - set(data))
    if unknown or missing:
        raise ValueError(f"{yaml_path}: missing sections {missing}, unknown sections {unknown}")
    load_power_spec(yaml_path)  # the power section fails here, at load, naming file and field
    urdf_path = (yaml_path.parent / str(data["urdf"])).resolve()
    body = inspect_urdf(urdf_path)
    links = _links(data["mass_properties"], yaml_path)
    _check_urdf_against_links(body, links, urdf_path)
    rotors = _rotors(data["rotors"], links, yaml_path)
    spec = MultirotorSpec(
        name=yaml_path.stem,
        description=str(data["description"]).strip(),
        source=str(data["source"]).strip(),
        yaml_path=yaml_path,
        urdf_path=urdf_path,
        mass_kg=body.mass_kg,
        inertia_diag_kg_m2=body.inertia_diag_kg_m2,
        links=links,
        ground_clearance_m=-body.lowest_point_m,
        motor=_build(MotorParams, data["motor"], "motor", yaml_path),
        rotors=rotors,
        fuselage=_build(FuselageDrag, data["fuselage"], "fuselage", yaml_path),
        imu=_sensor_section(ImuParams, data["imu"], "imu", yaml_path),
        mag=_build(MagParams, data["mag"], "mag", yaml_path),
        baro=_sensor_section(BaroParams, data["baro"], "baro", yaml_path),
        gps=_sensor_section(GpsParams, data["gps"], "gps", yaml_path),
        px4_params=_px4_params(data["px4"], rotors, yaml_path),
    )
    rangefinders = _rangefinders(data.get("rangefinders"), spec.extent_m, yaml_path)
    camera = None if data.get("camera") is None else _camera(data["camera"], yaml_path)
    if camera is not None:
        try:
            spec.check_mount(camera)
        except ValueError as exc:
            raise ValueError(f"{yaml_path}: {exc}") from exc
    return dataclasses.replace(spec, rangefinders=rangefinders, camera=camera)


def _camera(data: Any, path: Path) -> CameraSpec:
    """The optional ``camera`` section: CameraSpec fields (omitted ones keep their defaults)."""
    if not isinstance(data, dict):
        raise ValueError(f"{path}: section 'camera' must be a mapping")
    names = {f.name for f in dataclasses.fields(CameraSpec)}
    values = {k: v for k, v in data.items() if k not in ("description", "source")}
    unknown = sorted(set(values) - names)
    if unknown:
        raise ValueError(
            f"{path}: section 'camera': unknown keys {unknown} (known: {sorted(names)})"
        )
    if "position_frd_m" in values and isinstance(values["position_frd_m"], list):
        values["position_frd_m"] = tuple(values["position_frd_m"])
    try:
        return CameraSpec(**values)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: section 'camera': {exc}") from exc
