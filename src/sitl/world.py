"""The simulated world: N multirotors in PyBullet, stepped in lockstep, speaking PX4 HIL messages.

One ``World`` owns the simulation clock, the PyBullet scene, the rotors, the sensors, the power
system (LiPo packs) and one seeded random generator. Each ``step`` advances the physics by one
step; ``poll_sensors`` returns the HIL_SENSOR / HIL_GPS messages, ``poll_battery`` the
BATTERY_STATUS and ``poll_rangefinders`` the DISTANCE_SENSOR messages that are due at the current
time, ``poll_cameras`` the camera frames (with ``WorldConfig.cameras``); call them once after
each step.

Profile the hot loop with ``python -m sitl.world --profile``.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl import frames, hil
from sitl.clock import SimClock, rate_divisor
from sitl.physics.bullet import GROUND_TILE_M, BulletScene
from sitl.physics.earth import isa_pressure_pa, isa_temperature_k
from sitl.physics.geomagnetism import GeomagneticField, world_magnetic_model
from sitl.physics.ground_texture import ground_texture
from sitl.physics.moving_solids import MOVING_SOLIDS_HZ, MovingSolids
from sitl.physics.obstacles import BoxObstacle, add_boxes, add_solids
from sitl.physics.rotor_kernel import commands_from_controls
from sitl.physics.rotors import RotorModel
from sitl.physics.spills import OilSpills, add_people
from sitl.physics.surface_texture import surface_texture
from sitl.physics.wind import WindConfig, WindField
from sitl.power.loads import PayloadLoads
from sitl.power.propulsion import load_power_spec
from sitl.power.system import FleetPower
from sitl.sensors.baro import Barometer, BaroSample
from sitl.sensors.camera import CameraFrame, CameraSpec
from sitl.sensors.camera_render import CameraRig
from sitl.sensors.gps import Gps, GpsOutages, SharedGnssError
from sitl.sensors.imu import Imu
from sitl.sensors.mag import Magnetometer
from sitl.sensors.mocap import Mocap, MocapParams, MocapSample
from sitl.sensors.rangefinder import RangefinderArray
from sitl.truth import TruthState
from sitl.vehicles.multirotor import MultirotorSpec, airframe_yaml_path, load_airframe
from worlds import OilSpill, Person
from worlds import World as WorldsWorld

log = logging.getLogger(__name__)

ActuatorInput = mavlink2.MAVLink_hil_actuator_controls_message | None
"""What ``World.step`` takes per vehicle: a HIL_ACTUATOR_CONTROLS, or None to keep the last."""


@dataclass(frozen=True)
class WorldConfig:
    """Configuration of a world; validated on construction (``ValueError`` with the reason)."""

    n_vehicles: int = 1
    """Number of vehicles, >= 1."""
    spacing_m: float = 5.0
    """Distance between spawn points along ENU x (east), m."""
    physics_hz: float = 500.0
    """Physics rate, Hz."""
    imu_hz: float = 250.0
    """HIL_SENSOR rate (accelerometer and gyroscope), Hz; divides physics_hz."""
    gps_hz: float = 10.0
    """HIL_GPS rate, Hz; divides physics_hz."""
    baro_hz: float = 50.0
    """Barometer rate inside HIL_SENSOR, Hz; divides physics_hz, <= imu_hz."""
    mag_hz: float = 100.0
    """Magnetometer rate inside HIL_SENSOR, Hz; divides physics_hz, <= imu_hz."""
    seed: int = 0
    """Seed of the world's random generator (every sensor error)."""
    origin_lat_deg: float = 47.397742
    """Latitude of the world origin (ENU 0, 0, 0), degrees."""
    origin_lon_deg: float = 8.545594
    """Longitude of the world origin, degrees."""
    origin_alt_amsl_m: float = 488.0
    """Altitude of the ground plane above mean sea level, m."""
    airframe: str | tuple[str, ...] = "typhoon_h480"
    """Airframe of every vehicle, or a tuple with one per vehicle (vehicle order). Each is the name
    of a folder of ``sitl/vehicles`` or the path of a user's airframe folder."""
    spawn_altitude_m: float | None = None
    """None: spawn resting on the surface below; else height of the centre of mass above that
    surface (the ground, or ``spawn_enu_m``'s surface_z), m."""
    mag_model_decimal_year: float = 2026.0
    """Date of the world magnetic model (WMM2025, valid 2025.0-2030.0), decimal year
    (2026.0 = 2026-01-01; see ``sitl.physics.geomagnetism.decimal_year``)."""
    mag_declination_deg: float | None = None
    """Magnetic declination, degrees east of true north; None: the WMM's at the origin."""
    mag_inclination_deg: float | None = None
    """Magnetic inclination, degrees below the horizontal; None: the WMM's at the origin."""
    mag_strength_gauss: float | None = None
    """Strength of the Earth magnetic field, gauss; None: the WMM's at the origin."""
    gps_outages: GpsOutages = field(default_factory=GpsOutages)
    """When GNSS receivers lose their fix (scripted windows, random process); default never."""
    mocap_hz: float = 0.0
    """Rate of the emulated motion-capture system (``poll_mocap``), Hz; 0: off; divides
    physics_hz."""
    mocap: MocapParams = field(default_factory=MocapParams)
    """Noise and latency of the motion-capture system."""
    wind: WindConfig | None = None
    """Steady wind, turbulence and gusts; None: calm air."""
    battery_hz: float = 50.0
    """Rate of the power model update and of BATTERY_STATUS, Hz; divides physics_hz."""
    loads: tuple[PayloadLoads, ...] = (PayloadLoads(),)
    """Avionics and payload loads: one entry for every vehicle, or one per vehicle."""
    bench_supply: bool = False
    """Power the rotors from an ideal constant-voltage supply instead of the LiPo pack."""
    battery_soc: float = 1.0
    """State of charge of every pack at the start, 0..1."""
    battery_capacity_mah: tuple[float | None, ...] | None = None
    """Capacity of each vehicle's pack, mAh (one entry per vehicle; None, or a None entry: the
    airframe's ``power.battery.capacity_mah``)."""
    obstacles: tuple[BoxObstacle, ...] = ()
    """Static boxes (walls, pillars) the vehicles can hit and the sensors see."""
    scene: WorldsWorld | None = None
    """A built ``worlds`` world whose solids (boxes, vertical cylinders; moving ones follow their
    ``motion``) are added to the scene after ``obstacles``, with its people (upright cylinders)
    and oil spills (dark visual-only patches from their ``appear_s``); None: no scenery beyond
    ``obstacles``. Its wind and launch areas are the harness's to apply (``wind``,
    ``spawn_enu_m``; see docs/worlds.md, "In the simulator")."""
    rangefinders: bool = False
    """Fly the airframes' ultrasonic rangefinders (their ``rangefinders`` section); off (the
    default): none, ``poll_rangefinders`` returns None and a flight-only run pays nothing."""
    cameras: bool = False
    """Render the vehicles' cameras (``poll_cameras``); off: no camera costs anything."""
    spawn_enu_m: tuple[tuple[float, float, float], ...] | None = None
    """One (east, north, surface_z) per vehicle, m: the point of a surface (the ground z = 0, a
    helideck at 30 m, ...) where the vehicle rests; its centre of mass starts its resting height
    (or ``spawn_altitude_m``) above surface_z. None: (i * spacing_m, 0, 0) (see
    ``worlds.launch.spawn_points`` for points inside a launch area)."""
    camera: CameraSpec | tuple[CameraSpec | None, ...] | None = None
    """With ``cameras``, overrides the airframes' cameras: one CameraSpec for every vehicle, or a
    tuple with one entry per vehicle (None: that vehicle has no camera). None: each airframe's
    own camera (the YAML's ``camera`` section; vehicles without one have none)."""

    def __post_init__(self) -> None:
        if isinstance(self.n_vehicles, bool) or not isinstance(self.n_vehicles, int):
            raise ValueError(f"n_vehicles must be an int, got {self.n_vehicles!r}")
        if self.n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {self.n_vehicles}")
        if not self.physics_hz > 0.0:
            raise ValueError(f"physics_hz must be positive, got {self.physics_hz!r}")
        for name in ("imu_hz", "gps_hz", "baro_hz", "mag_hz", "battery_hz"):
            rate_divisor(self.physics_hz, getattr(self, name), name)
        if self.mocap_hz:
            rate_divisor(self.physics_hz, self.mocap_hz, "mocap_hz")
        for name in ("baro_hz", "mag_hz"):
            if getattr(self, name) > self.imu_hz:
                raise ValueError(
                    f"{name}={getattr(self, name):g} Hz exceeds imu_hz={self.imu_hz:g} Hz: "
                    "barometer and magnetometer travel inside HIL_SENSOR, sent at imu_hz"
                )
        if self.n_vehicles > 1 and not self.spacing_m > 0.0:
            raise ValueError(f"spacing_m must be positive with several vehicles: {self.spacing_m}")
        if not -90.0 <= self.origin_lat_deg <= 90.0:
            raise ValueError(f"origin_lat_deg out of [-90, 90]: {self.origin_lat_deg}")
        if not -180.0 <= self.origin_lon_deg <= 180.0:
            raise ValueError(f"origin_lon_deg out of [-180, 180]: {self.origin_lon_deg}")
        if self.spawn_altitude_m is not None and not self.spawn_altitude_m > 0.0:
            raise ValueError(f"spawn_altitude_m must be positive or None: {self.spawn_altitude_m}")
        if self.spawn_enu_m is not None:
            object.__setattr__(
                self, "spawn_enu_m", _spawn_points(self.spawn_enu_m, self.n_vehicles)
            )
        if self.mag_strength_gauss is not None and not self.mag_strength_gauss > 0.0:
            raise ValueError(f"mag_strength_gauss must be positive: {self.mag_strength_gauss}")
        if isinstance(self.airframe, os.PathLike):
            object.__setattr__(self, "airframe", os.fspath(self.airframe))
        names = (self.airframe,) if isinstance(self.airframe, str) else tuple(self.airframe)
        if len(names) not in (1, self.n_vehicles):
            raise ValueError(
                f"airframe: {len(names)} names for {self.n_vehicles} vehicles (give one for all, "
                "or one per vehicle)"
            )
        for name in names:
            airframe_yaml_path(name)  # ValueError naming the unknown airframe
        object.__setattr__(self, "obstacles", tuple(self.obstacles))
        for k, box in enumerate(self.obstacles):
            if not isinstance(box, BoxObstacle):
                raise ValueError(f"obstacles[{k}] must be a BoxObstacle, got {box!r}")
        if self.scene is not None and not isinstance(self.scene, WorldsWorld):
            raise ValueError(f"scene must be a worlds.World or None, got {type(self.scene)!r}")
        if not 0.0 <= self.battery_soc <= 1.0:
            raise ValueError(f"battery_soc must be in [0, 1], got {self.battery_soc!r}")
        if self.battery_capacity_mah is not None:
            caps = tuple(None if c is None else float(c) for c in self.battery_capacity_mah)
            object.__setattr__(self, "battery_capacity_mah", caps)
            if len(caps) != self.n_vehicles:
                raise ValueError(
                    f"battery_capacity_mah: {len(caps)} entries for {self.n_vehicles} vehicles"
                )
            for k, c in enumerate(caps):
                if c is not None and not c > 0.0:
                    raise ValueError(f"battery_capacity_mah[{k}] must be positive, got {c!r}")
        if len(self.loads) not in (1, self.n_vehicles):
            raise ValueError(
                f"loads needs 1 or n_vehicles={self.n_vehicles} entries, got {len(self.loads)}"
            )
        if self.camera is not None:
            if not self.cameras:
                raise ValueError("camera: a camera spec is given but cameras=False")
            if isinstance(self.camera, CameraSpec):
                rate_divisor(self.physics_hz, self.camera.rate_hz, "camera.rate_hz")
            else:
                object.__setattr__(self, "camera", tuple(self.camera))
                if len(self.camera) != self.n_vehicles:
                    raise ValueError(
                        f"camera: {len(self.camera)} entries for {self.n_vehicles} vehicles (give "
                        "one CameraSpec for all, or one entry per vehicle)"
                    )
                for k, spec in enumerate(self.camera):
                    if spec is not None and not isinstance(spec, CameraSpec):
                        raise ValueError(f"camera[{k}] must be a CameraSpec or None, got {spec!r}")
                    if spec is not None:
                        rate_divisor(self.physics_hz, spec.rate_hz, f"camera[{k}].rate_hz")
        if self.wind is not None:
            if not isinstance(self.wind, WindConfig):
                raise ValueError(f"wind must be a WindConfig or None, got {self.wind!r}")
            rate_divisor(self.physics_hz, self.wind.update_hz, "wind update_hz")

    @property
    def airframes(self) -> tuple[str, ...]:
        """The airframe of each vehicle, in vehicle order."""
        if isinstance(self.airframe, str):
            return (self.airframe,) * self.n_vehicles
        names = tuple(os.fspath(name) for name in self.airframe)
        return names * self.n_vehicles if len(names) == 1 else names


@dataclass(eq=False)
class _AirframeGroup:
    """The vehicles of one airframe: their rotors, commands and sensors (arrays of the group)."""

    spec: MultirotorSpec
    rows: slice | np.ndarray
    """Vehicle indices of the group: a slice when contiguous (views), else an index array."""
    n: int
    rotors: RotorModel
    imu: Imu
    mag: Magnetometer
    baro: Barometer
    gps: Gps
    power: FleetPower

    def __post_init__(self) -> None:
        shape = (self.n, len(self.spec.rotors))
        self.ones = np.ones(shape)
        self.max_speed_rad_s = np.full(shape, self.spec.motor.max_speed_rad_s)
        self.controls = np.zeros(shape)


def _group_rows(indices: list[int]) -> slice | np.ndarray:
    if indices == list(range(indices[0], indices[-1] + 1)):
        return slice(indices[0], indices[-1] + 1)
    return np.array(indices)


class World:
    """N multirotors in a PyBullet DIRECT world, advanced in lockstep.

    Vehicle i spawns at ENU (i * spacing_m, 0, h), facing north, with h the resting height of the
    centre of mass (or ``spawn_altitude_m``); with ``spawn_enu_m`` at (east, north, surface_z + h).
    Commands arrive as HIL_ACTUATOR_CONTROLS (controls in [0, 1] in the airframe's output order;
    zero unless the mode has SAFETY_ARMED); sensors leave as HIL_SENSOR and HIL_GPS, one message
    per vehicle in vehicle order.

    Vehicles may have different airframes (rotor counts, URDFs, sensor parameters): the vehicles of
    one airframe form a group with its own rotor model and sensors, each vectorised over the group.
    """

    def __init__(self, config: WorldConfig) -> None:
        self.config = config
        n = config.n_vehicles
        self.n_vehicles = n
        loaded: dict[str, MultirotorSpec] = {}
        members: dict[str, list[int]] = {}
        for i, name in enumerate(config.airframes):
            if name not in loaded:
                loaded[name] = load_airframe(name)
                members[name] = []
            members[name].append(i)
        self.airframes: tuple[MultirotorSpec, ...] = tuple(loaded[a] for a in config.airframes)
        """The airframe of each vehicle, in vehicle order."""
        self.airframe: MultirotorSpec = self.airframes[0]
        """Vehicle 0's airframe (every vehicle's with a single airframe)."""
        self._clock = SimClock(config.physics_hz)
        dt = self._clock.dt_s
        self._imu_div = rate_divisor(config.physics_hz, config.imu_hz, "imu_hz")
        self._baro_div = rate_divisor(config.physics_hz, config.baro_hz, "baro_hz")
        self._mag_div = rate_divisor(config.physics_hz, config.mag_hz, "mag_hz")
        self.origin = frames.GeodeticOrigin(
            config.origin_lat_deg, config.origin_lon_deg, config.origin_alt_amsl_m
        )

        heights = np.array([spec.ground_clearance_m for spec in self.airframes])
        if config.spawn_altitude_m is not None:
            lowest = int(np.argmax(heights))
            if config.spawn_altitude_m < heights[lowest]:
                spec = self.airframes[lowest]
                raise ValueError(
                    f"spawn_altitude_m={config.spawn_altitude_m} m is below the resting height "
                    f"{heights[lowest]:.3f} m of {spec.name}'s centre of mass"
                )
            heights[:] = float(config.spawn_altitude_m)
        if config.spawn_enu_m is None:
            self._spawn_enu = np.array([[i * config.spacing_m, 0.0, heights[i]] for i in range(n)])
        else:
            self._spawn_enu = np.array(config.spawn_enu_m, dtype=float)
            self._spawn_enu[:, 2] += heights
        facing_north = frames.quat_ned_frd_to_enu_flu(frames.quat_from_euler_ned_frd(0, 0, 0))
        self._scene = BulletScene(
            [spec.urdf_path for spec in self.airframes], self._spawn_enu, tuple(facing_north), dt
        )
        self.obstacle_ids: list[int] = add_boxes(self._scene.client_id, config.obstacles)
        """PyBullet body ids of ``config.obstacles``, then of ``config.scene``'s solids."""
        self._moving_solids: MovingSolids | None = None
        self._spills: OilSpills | None = None
        self.person_ids: list[int] = []
        """PyBullet body ids of ``config.scene``'s people (upright cylinders), in target order."""
        self._moving_div = max(1, round(config.physics_hz / MOVING_SOLIDS_HZ))
        if config.scene is not None:
            solid_ids = add_solids(self._scene.client_id, config.scene.solids)
            self.obstacle_ids.extend(solid_ids)
            movers = MovingSolids(self._scene.client_id, config.scene.solids, solid_ids)
            if len(movers):
                self._moving_solids = movers
            targets = config.scene.targets
            people = [t for t in targets if isinstance(t, Person)]
            self.person_ids = add_people(self._scene.client_id, people)
            spills = [t for t in targets if isinstance(t, OilSpill)]
            if spills:
                self._spills = OilSpills(self._scene.client_id, spills)
        self._scene_updates = self._moving_solids is not None or self._spills is not None

        # Sensor construction order fixes the order of random draws: keep it (group by group in
        # order of first appearance; one group is the single-airframe world).
        rng = np.random.default_rng(config.seed)
        self._power_div = rate_divisor(config.physics_hz, config.battery_hz, "battery_hz")
        loads = config.loads * n if len(config.loads) == 1 else config.loads
        alt = np.array(config.origin_alt_amsl_m)
        air_density = float(isa_pressure_pa(alt) / (287.05 * isa_temperature_k(alt)))
        self.magnetic_field = _magnetic_field(config)
        """The Earth field at the origin the magnetometers measure (WMM unless overridden)."""
        field = self.magnetic_field.ned_gauss()
        self._groups: list[_AirframeGroup] = []
        caps = config.battery_capacity_mah or (None,) * n
        for name, spec in loaded.items():
            size = len(members[name])
            power_spec = load_power_spec(spec.yaml_path)
            self._groups.append(
                _AirframeGroup(
                    spec=spec,
                    rows=_group_rows(members[name]),
                    n=size,
                    rotors=RotorModel(spec.motor, spec.rotors, spec.fuselage, size, dt),
                    imu=Imu(spec.imu, size, rng),
                    mag=Magnetometer(spec.mag, field, size, rng),
                    baro=Barometer(spec.baro, size, rng),
                    # The receivers draw from their own stream, spawned from (not drawn from)
                    # the world's generator: their satellites, outages and errors never shift
                    # another sensor's draws.
                    gps=Gps(
                        spec.gps,
                        self.origin,
                        size,
                        rng.spawn(1)[0],
                        config.gps_outages,
                        physics_hz=config.physics_hz,
                        gps_hz=config.gps_hz,
                        rows=_group_rows(members[name]),
                    ),
                    power=FleetPower(
                        power_spec,
                        spec.motor.thrust_coefficient_n_s2_rad2,
                        spec.motor.max_speed_rad_s,
                        len(spec.rotors),
                        air_density,
                        [loads[i] for i in members[name]],
                        config.bench_supply,
                        config.battery_soc,
                        [
                            power_spec.battery.capacity_mah if caps[i] is None else caps[i]
                            for i in members[name]
                        ],
                    ),
                )
            )
        self._single = self._groups[0] if len(self._groups) == 1 else None
        self._max_rotors = max(len(spec.rotors) for spec in loaded.values())
        self._controls = np.zeros((n, self._max_rotors))
        self._wrench = np.zeros((n, 6))
        self._nan_logged = False
        # The wind draws from a child of the world's generator, spawned after the sensors were
        # built and whether or not there is wind: the sensors' draws are the same with and
        # without wind, and the wind's own stream depends only on the seed.
        wind_rng = rng.spawn(1)[0]
        self._wind: WindField | None = None
        self._air_row = np.zeros((n, 1, 3))
        self._air_flu = np.zeros((n, 1, 3))
        if config.wind is not None:
            self._wind_div = rate_divisor(config.physics_hz, config.wind.update_hz, "update_hz")
            self._wind = WindField(config.wind, n, self._wind_div * dt, wind_rng)
        self._mocap = Mocap(config.mocap, n, rng.spawn(1)[0])
        self._mocap_div = (
            rate_divisor(config.physics_hz, config.mocap_hz, "mocap_hz") if config.mocap_hz else 0
        )
        self._mocap_latency_s = (
            round(config.mocap.latency_ms * 1e-3 * config.physics_hz) * self._clock.dt_s
        )
        self._last_mocap_tick = -1
        # The rangefinders' noise and dropouts come from a child spawned after every other one:
        # switching them on or off changes no other sensor's draws.
        self.rangefinders = RangefinderArray(
            self._scene.client_id,
            self._scene.body_ids,
            [spec.rangefinders if config.rangefinders else () for spec in self.airframes],
            config.physics_hz,
            rng.spawn(1)[0],
        )
        """Every vehicle's rangefinders (none when ``config.rangefinders`` is False)."""
        self._last_range_tick = -1
        self._battery_due = True
        for group in self._groups:
            self._apply_speed_limit(group)

        self._last_poll_tick = -1
        self._last_tick = {"imu": -1, "mag": -1, "baro": -1}
        self._next_mag_tick = 0
        self._next_baro_tick = 0
        # HIL_SENSOR values, body FRD: specific force, angular rate, magnetic field (views).
        self._imu_mag_frd = np.zeros((n, 9))
        self._imu_frd = self._imu_mag_frd[:, :6].reshape(n, 2, 3)
        self._mag_frd = self._imu_mag_frd[:, 6:]
        assert np.shares_memory(self._imu_frd, self._imu_mag_frd), "must be a view"
        # Magnetometer and barometer fall due at tick 0, so they are sampled for (at the latest)
        # the first HIL_SENSOR, whenever the first poll happens.
        self._baro_sample: BaroSample | None = None
        # The scenery (ground texture) draws from its own child generator, spawned after every
        # other one, with or without cameras: no other stream changes.
        scenery_rng = rng.spawn(1)[0]
        # The GNSS error the receivers share (atmosphere, satellite clocks and orbits): one for
        # the world, across airframe groups; spawned last, so that no other stream moves.
        shared_gnss = SharedGnssError(rng.spawn(1)[0])
        for group in self._groups:
            group.gps.shared_error = shared_gnss
        self._cameras: CameraRig | None = None
        self._last_camera_tick = -1
        if config.cameras:
            self._cameras = self._build_cameras(scenery_rng)

    def _build_cameras(self, scenery_rng: np.random.Generator) -> CameraRig | None:
        """The camera rig (None if no vehicle has a camera), with the scenery the cameras see."""
        config = self.config
        specs: list[CameraSpec | None] = []
        for i, airframe in enumerate(self.airframes):
            if config.camera is None:
                spec, where = airframe.camera, f"{airframe.name} camera"
            elif isinstance(config.camera, CameraSpec):
                spec, where = config.camera, "camera"
            else:
                spec, where = config.camera[i], f"camera[{i}]"
            if spec is not None:
                airframe.check_mount(spec, where)
                rate_divisor(config.physics_hz, spec.rate_hz, f"{where}.rate_hz")
            specs.append(spec)
        if all(spec is None for spec in specs):
            return None
        scene = self._scene
        if config.scene is None:
            texture, tile_m = ground_texture(scenery_rng, tile_m=GROUND_TILE_M), GROUND_TILE_M
        else:
            texture, tile_m = surface_texture(scenery_rng, config.scene.surface)
        rig = CameraRig(
            scene.client_id,
            specs,
            config.physics_hz,
            texture,
            tile_m,
            scene.ground_id,
            scene.body_ids,
            filtered_ground=config.scene is not None,
        )
        if self._spills is not None:
            rig.bound_visuals(self._spills.visual_corners_local)
        checked: set[tuple[str, CameraSpec]] = set()  # same airframe, same camera: same view
        for i, spec in enumerate(specs):
            key = (str(self.airframes[i].urdf_path), spec)
            if spec is None or key in checked:
                continue
            checked.add(key)
            own = scene.body_ids[i]
            if own in rig.visible_bodies(i, scene.position_enu_m[i], scene.rotation[i]):
                raise ValueError(
                    f"camera of vehicle {i} ({self.airframes[i].name}): its own body is in view "
                    f"from position_frd_m={spec.position_frd_m}, pitch_deg={spec.pitch_deg:g}, "
                    f"yaw_deg={spec.yaw_deg:g}, hfov_deg={spec.hfov_deg:g}; mount it lower, "
                    "farther out or narrow the field of view"
                )
        return rig

    # -- time ---------------------------------------------------------------------------------

    @property
    def time_s(self) -> float:
        """Simulation time since the start, s (the only clock)."""
        return self._clock.time_s

    # -- the hot loop -------------------------------------------------------------------------

    def step(self, actuators: Sequence[ActuatorInput] | None = None) -> None:
        """Advance the physics by one step of ``1 / physics_hz``.

        Args:
            actuators: one entry per vehicle: a HIL_ACTUATOR_CONTROLS message, or None to keep that
                vehicle's previous command. None for the whole argument keeps every command.
        """
        if actuators is not None:
            if len(actuators) != self.n_vehicles:
                raise ValueError(
                    f"expected {self.n_vehicles} actuator entries, got {len(actuators)}"
                )
            nan_seen = hil.read_actuator_controls(actuators, self._controls)
            if nan_seen is not None:
                self._update_rotor_commands(nan_seen)
        scene = self._scene
        velocity_flu = scene.velocity_flu_m_s if self._wind is None else self._airspeed_flu()
        single = self._single
        if single is not None:
            scene.apply_body_wrench_and_step(single.rotors.step(velocity_flu))
        else:
            for group in self._groups:
                rows = group.rows
                self._wrench[rows] = group.rotors.step(velocity_flu[rows])
            scene.apply_body_wrench_and_step(self._wrench)
        self._clock.advance()
        if self._scene_updates and self._clock.tick % self._moving_div == 0:
            if self._moving_solids is not None:
                self._moving_solids.update(self._clock.time_s)
            if self._spills is not None:
                self._spills.update(self._clock.time_s)
        if self._clock.tick % self._power_div == 0:
            dt = self._power_div * self._clock.dt_s
            for group in self._groups:
                group.power.update(group.rotors.speed_rad_s, dt)
                self._apply_speed_limit(group)
            self._battery_due = True

    def _apply_speed_limit(self, group: _AirframeGroup) -> None:
        """Rotor speed at full command from the supply voltage; re-scale the group's commands."""
        limit = group.spec.motor.max_speed_rad_s * group.power.speed_scale
        np.multiply(group.ones, limit[:, None], out=group.max_speed_rad_s)
        u = self._controls if self._single is not None else group.controls
        np.multiply(u, group.max_speed_rad_s, out=group.rotors.command_rad_s)

    @property
    def power(self) -> FleetPower:
        """Electrical state (packs, power, rotor speed limit) of vehicle 0's airframe group.

        In a single-airframe world that is every vehicle (see :meth:`power_of`).
        """
        return self._groups[0].power if self._single is not None else self.power_of(0)

    def power_of(self, i: int) -> FleetPower:
        """The power model of vehicle i's airframe group (its arrays hold the group's vehicles)."""
        for group in self._groups:
            if i in group.gps.vehicle_ids:
                return group.power
        raise IndexError(f"vehicle index {i} out of range 0..{self.n_vehicles - 1}")

    def rotor_power_w(self) -> np.ndarray:
        """Electrical power of each vehicle's rotors now, W, (N,) in vehicle order (a copy).

        What an energy ledger integrates as propulsion (the payload loads are separate).
        """
        return self._power_column(lambda group: group.power.rotor_power_w)

    def _power_column(self, get: Callable[[_AirframeGroup], np.ndarray]) -> np.ndarray:
        """One (N,) array in vehicle order from every airframe group (a copy)."""
        if self._single is not None:
            return np.array(get(self._single), dtype=float)
        out = np.zeros(self.n_vehicles)
        for group in self._groups:
            out[group.rows] = get(group)
        return out

    def _airspeed_flu(self) -> np.ndarray:
        """Velocity relative to the air, body FLU, (N, 1, 3): what rotor and fuselage drag see."""
        scene = self._scene
        wind = self._wind
        assert wind is not None
        if self._clock.tick % self._wind_div == 0:
            wind.update(scene.position_enu_m, scene.velocity_enu_m_s)
        np.subtract(scene.velocity_enu_m_s, wind.velocity_enu_m_s, self._air_row[:, 0, :])
        return np.matmul(self._air_row, scene.rotation, self._air_flu)

    def _update_rotor_commands(self, nan_seen: bool) -> None:
        if nan_seen and not self._nan_logged:
            log.warning("NaN motor command received; treating it as 0 (logged once per world)")
            self._nan_logged = True
        for group in self._groups:
            if self._single is not None:
                u = self._controls  # every row is this group's: no copy
            else:
                u = group.controls
                u[:] = self._controls[group.rows, : u.shape[1]]
            commands_from_controls(u, group.max_speed_rad_s, group.rotors.command_rad_s)

    # -- sensors ------------------------------------------------------------------------------

    def poll_sensors(
        self,
    ) -> tuple[
        list[mavlink2.MAVLink_hil_sensor_message] | None,
        list[mavlink2.MAVLink_hil_gps_message] | None,
    ]:
        """Messages that became due at the current time, one per vehicle, or None if none is due.

        HIL_SENSOR is due every ``physics_hz / imu_hz`` steps; it flags the magnetometer and the
        barometer when they were sampled for it (at their own rates, on the first IMU sample at or
        after they fall due). HIL_GPS is due every ``physics_hz / gps_hz`` steps and carries the
        fix measured the receiver's delay earlier (rounded to a physics step); until the first
        such fix exists it reports no fix. A second call at the same time returns
        ``(None, None)``. Call it after every step: a skipped step can skip a measurement.
        """
        tick = self._clock.tick
        if tick == self._last_poll_tick:
            return None, None
        self._last_poll_tick = tick
        sensors = self._sample_hil_sensor(tick) if tick % self._imu_div == 0 else None
        return sensors, self._poll_hil_gps(tick)

    def poll_mocap(self) -> list[MocapSample]:
        """Motion-capture samples released at the current time (empty when off or none due).

        A sample is measured every ``physics_hz / mocap_hz`` steps and released its latency
        (rounded to a physics step) later. Call after every step, as ``poll_sensors``.
        """
        if not self._mocap_div:
            return []
        tick = self._clock.tick
        if tick != self._last_mocap_tick:
            self._last_mocap_tick = tick
            if tick % self._mocap_div == 0:
                scene = self._scene
                self._mocap.measure(self._clock.time_s, scene.position_enu_m, scene.quaternion_xyzw)
        return self._mocap.release(self._clock.time_s, self._mocap_latency_s)

    def poll_rangefinders(self) -> list[list[mavlink2.MAVLink_distance_sensor_message]] | None:
        """DISTANCE_SENSOR of the rangefinders due now, one list per vehicle (vehicle order).

        None when no rangefinder is due (or there are none); a vehicle with no sensor due has an
        empty list. All due rays of all vehicles are cast in one batch. Call after every step, as
        ``poll_sensors``; a second call at the same time returns None.
        """
        tick = self._clock.tick
        if tick == self._last_range_tick or not self.rangefinders.due(tick):
            return None
        self._last_range_tick = tick
        scene = self._scene
        readings = self.rangefinders.sample(
            tick, self._clock.time_usec, scene.position_enu_m, scene.rotation
        )
        if readings is None:
            return None
        return hil.distance_sensor_messages(readings, self.n_vehicles)

    def poll_battery(self) -> list[mavlink2.MAVLink_battery_status_message] | None:
        """BATTERY_STATUS per vehicle (power module: voltage, current) when due, else None.

        Due at ``battery_hz`` (and at the start); a second call at the same time returns None.
        """
        if not self._battery_due:
            return None
        self._battery_due = False
        return hil.battery_status_messages(
            self._power_column(lambda g: g.power.voltage_v),
            self._power_column(lambda g: g.power.current_a),
        )

    @property
    def camera_specs(self) -> tuple[CameraSpec | None, ...]:
        """Each vehicle's camera (None: no camera; all None when ``cameras`` is off)."""
        if self._cameras is None:
            return (None,) * self.n_vehicles
        return self._cameras.specs

    def poll_cameras(self) -> list[CameraFrame] | None:
        """The frames taken at the current time, in vehicle order, or None if none is due.

        Every camera renders once per ``physics_hz / rate_hz`` steps, all due cameras in one pass
        (nothing is rendered between). A second call at the same time returns None. Call it after
        every step, as ``poll_sensors``: a skipped step can skip a frame.
        """
        rig = self._cameras
        if rig is None:
            return None
        tick = self._clock.tick
        if tick == self._last_camera_tick or not rig.due(tick):
            return None
        self._last_camera_tick = tick
        scene = self._scene
        frames = rig.render_due(
            tick, self._clock.time_s, scene.position_enu_m, scene.rotation, scene.quaternion_xyzw
        )
        return frames or None

    def _interval_s(self, sensor: str, tick: int, divisor: int) -> float:
        """Time since the sensor's previous sample (its nominal period for the first one)."""
        last = self._last_tick[sensor]
        self._last_tick[sensor] = tick
        return (tick - last if last >= 0 else divisor) * self._clock.dt_s

    def _sample_hil_sensor(self, tick: int) -> list[mavlink2.MAVLink_hil_sensor_message]:
        scene = self._scene
        single = self._single
        dt_imu = self._interval_s("imu", tick, self._imu_div)
        mag_due = tick >= self._next_mag_tick
        baro_due = tick >= self._next_baro_tick
        dt_mag = self._interval_s("mag", tick, self._mag_div) if mag_due else 0.0
        dt_baro = self._interval_s("baro", tick, self._baro_div) if baro_due else 0.0
        alt = self.origin.alt_amsl_m + scene.position_enu_m[:, 2] if baro_due else None
        if single is not None:
            single.imu.sample(
                scene.rotation,
                scene.velocity_enu_m_s,
                scene.angular_velocity_enu_rad_s,
                dt_imu,
                out=self._imu_frd,
            )
            if mag_due:
                single.mag.sample(scene.rotation, dt_mag, out=self._mag_frd)
            if baro_due:
                self._baro_sample = single.baro.sample(alt, dt_baro)
        else:
            baro_parts = []
            for group in self._groups:
                rows = group.rows
                rotation = scene.rotation[rows]
                imu_out = np.empty((group.n, 2, 3))
                group.imu.sample(
                    rotation,
                    scene.velocity_enu_m_s[rows],
                    scene.angular_velocity_enu_rad_s[rows],
                    dt_imu,
                    out=imu_out,
                )
                self._imu_frd[rows] = imu_out
                if mag_due:
                    mag_out = np.empty((group.n, 3))
                    group.mag.sample(rotation, dt_mag, out=mag_out)
                    self._mag_frd[rows] = mag_out
                if baro_due:
                    baro_parts.append((rows, group.baro.sample(alt[rows], dt_baro)))
            if baro_due:
                self._baro_sample = self._merge_baro(baro_parts)
        fields = hil.FIELDS_IMU
        if mag_due:
            self._next_mag_tick = (tick // self._mag_div + 1) * self._mag_div
            fields |= hil.FIELDS_MAG
        if baro_due:
            self._next_baro_tick = (tick // self._baro_div + 1) * self._baro_div
            fields |= hil.FIELDS_BARO
        assert self._baro_sample is not None  # due at tick 0
        return hil.hil_sensor_messages(
            self._clock.time_usec, self._imu_mag_frd, self._baro_sample, fields
        )

    def _merge_baro(self, parts: list[tuple[slice | np.ndarray, BaroSample]]) -> BaroSample:
        """One BaroSample in vehicle order from the groups' samples."""
        merged = {f.name: np.empty(self.n_vehicles) for f in dataclasses.fields(BaroSample)}
        for rows, sample in parts:
            for name, values in merged.items():
                values[rows] = getattr(sample, name)
        return BaroSample(**merged)

    def _poll_hil_gps(self, tick: int) -> list[mavlink2.MAVLink_hil_gps_message] | None:
        """HIL_GPS of every vehicle when the receivers send (their fixes measured a delay ago)."""
        scene = self._scene
        time_usec = self._clock.time_usec
        if self._single is not None:
            fix = self._single.gps.poll(tick, scene.position_enu_m, scene.velocity_enu_m_s)
            return hil.hil_gps_messages(time_usec, fix) if fix is not None else None
        messages: list = [None] * self.n_vehicles
        sent = False
        for group in self._groups:
            fix = group.gps.poll(tick, scene.position_enu_m, scene.velocity_enu_m_s)
            if fix is None:
                continue
            sent = True
            for i, msg in zip(
                group.gps.vehicle_ids.tolist(), hil.hil_gps_messages(time_usec, fix), strict=True
            ):
                messages[i] = msg
        return messages if sent else None

    # -- truth and geometry -------------------------------------------------------------------

    @property
    def truth(self) -> TruthState:
        """True state of every vehicle now (a snapshot of copies)."""
        scene = self._scene
        rotation = scene.rotation
        return TruthState(
            time_s=self._clock.time_s,
            position_enu_m=scene.position_enu_m.copy(),
            velocity_enu_m_s=scene.velocity_enu_m_s.copy(),
            quaternion_xyzw=scene.quaternion_xyzw.copy(),
            angular_velocity_body_frd_rad_s=frames.world_enu_to_body_frd(
                rotation, scene.angular_velocity_enu_rad_s
            ),
            rotor_speed_rad_s=self._rotor_speeds(),
            electrical_power_w=self._power_column(
                lambda g: g.power.rotor_power_of(g.rotors.speed_rad_s) + g.power.loads_w
            ),
            battery_voltage_v=self._power_column(lambda g: g.power.voltage_v),
            battery_current_a=self._power_column(lambda g: g.power.current_a),
            battery_soc=self._power_column(lambda g: g.power.pack.soc),
            tilt_rad=np.arccos(np.clip(rotation[:, 2, 2], -1.0, 1.0)),
            wind_enu_m_s=(
                np.zeros((self.n_vehicles, 3))
                if self._wind is None
                else self._wind.velocity_enu_m_s.copy()
            ),
            origin=self.origin,
        )

    def _rotor_speeds(self) -> np.ndarray:
        """(N, most rotors of any airframe), rad/s; absent rotors of smaller airframes read 0."""
        if self._single is not None:
            return self._single.rotors.speed_rad_s.copy()
        speeds = np.zeros((self.n_vehicles, self._max_rotors))
        for group in self._groups:
            speeds[group.rows, : group.rotors.n_rotors] = group.rotors.speed_rad_s
        return speeds

    def home_geodetic(self, i: int) -> tuple[float, float, float]:
        """Latitude (deg), longitude (deg), altitude AMSL (m) of vehicle i's spawn point (CoM)."""
        if not 0 <= i < self.n_vehicles:
            raise IndexError(f"vehicle index {i} out of range 0..{self.n_vehicles - 1}")
        lat, lon, alt = frames.enu_to_geodetic(self._spawn_enu[i], self.origin)
        return float(lat), float(lon), float(alt)

    def close(self) -> None:
        """Release the PyBullet client (idempotent)."""
        self._scene.close()

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _spawn_points(points: object, n_vehicles: int) -> tuple[tuple[float, float, float], ...]:
    """``WorldConfig.spawn_enu_m`` as a tuple of float triples; ValueError naming the field."""
    try:
        rows = [tuple(float(v) for v in point) for point in points]  # type: ignore[attr-defined]
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"spawn_enu_m must be (east, north, surface_z) triples, got {points!r}"
        ) from exc
    if len(rows) != n_vehicles:
        raise ValueError(f"spawn_enu_m: {len(rows)} points for n_vehicles={n_vehicles}")
    for k, row in enumerate(rows):
        if len(row) != 3 or not all(math.isfinite(v) for v in row):
            raise ValueError(f"spawn_enu_m[{k}] must be 3 finite numbers, got {row}")
    return tuple(rows)  # type: ignore[return-value]


def _magnetic_field(config: WorldConfig) -> GeomagneticField:
    """The WMM field at the origin on the configured date, with the explicit overrides applied."""
    wmm = world_magnetic_model(
        config.origin_lat_deg,
        config.origin_lon_deg,
        config.origin_alt_amsl_m,
        config.mag_model_decimal_year,
    )
    return GeomagneticField(
        declination_deg=wmm.declination_deg
        if config.mag_declination_deg is None
        else float(config.mag_declination_deg),
        inclination_deg=wmm.inclination_deg
        if config.mag_inclination_deg is None
        else float(config.mag_inclination_deg),
        strength_gauss=wmm.strength_gauss
        if config.mag_strength_gauss is None
        else float(config.mag_strength_gauss),
    )


def hover_actuator_message(
    airframe: MultirotorSpec,
) -> mavlink2.MAVLink_hil_actuator_controls_message:
    """An armed HIL_ACTUATOR_CONTROLS commanding every rotor to the hover speed."""
    controls = [airframe.hover_command] * len(airframe.rotors) + [0.0] * (16 - len(airframe.rotors))
    return mavlink2.MAVLink_hil_actuator_controls_message(
        0, controls, mavlink2.MAV_MODE_FLAG_SAFETY_ARMED, 0
    )


def profile(
    n_vehicles: int,
    n_steps: int,
    airborne_steps: int = 1000,
    airframe: str | tuple[str, ...] = "typhoon_h480",
    wind: WindConfig | None = None,
) -> dict[str, float]:
    """Wall time per physics step, us (best 2 s chunk), with every rotor commanded to hover.

    Open-loop hover is unstable, so each measurement runs in fresh worlds spawned at 10 m for
    ``airborne_steps`` steps (2 s), before any vehicle could tip over and reach the ground (at
    100 m with ``wind``).

    Returns:
        ``step``: ``World.step`` alone; ``step+poll``: with ``poll_sensors`` after each step;
        ``pybullet``: ``stepSimulation`` alone on the same bodies in free fall (the floor).
    """
    from sitl.physics.bullet_import import pybullet as p  # only the profiler calls it directly

    # Wind tips an open-loop hover over within the 2 s: start high enough not to land.
    height_m = 10.0 if wind is None else 100.0

    def timed(poll: bool) -> float:
        # Best chunk (least disturbed by other processes), as timeit does.
        best, done = math.inf, 0
        while done < n_steps:
            config = WorldConfig(
                n_vehicles=n_vehicles, spawn_altitude_m=height_m, airframe=airframe, wind=wind
            )
            with World(config) as world:
                actuators = [hover_actuator_message(spec) for spec in world.airframes]
                world.step(actuators)
                world.poll_sensors()
                t0 = time.perf_counter()
                for _ in range(airborne_steps):
                    world.step(actuators)
                    if poll:
                        world.poll_sensors()
                best = min(best, (time.perf_counter() - t0) / airborne_steps)
                done += airborne_steps
        return best * 1e6

    results = {"step": timed(poll=False), "step+poll": timed(poll=True)}
    config = WorldConfig(n_vehicles=n_vehicles, spawn_altitude_m=1000.0, airframe=airframe)
    with World(config) as world:
        cid = world._scene.client_id
        best = math.inf
        for _ in range(max(1, n_steps // airborne_steps)):
            t0 = time.perf_counter()
            for _ in range(airborne_steps):
                p.stepSimulation(physicsClientId=cid)
            best = min(best, (time.perf_counter() - t0) / airborne_steps)
        results["pybullet"] = best * 1e6
    return results


def _main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m sitl.world", description=__doc__)
    parser.add_argument("--profile", action="store_true", help="print us per step, N = 1 and 10")
    parser.add_argument("--steps", type=int, default=20000, help="steps per measurement")
    parser.add_argument(
        "--frame",
        default="typhoon_h480",
        help="airframe, or a comma-separated list cycled over the vehicles: typhoon_h480,x500",
    )
    parser.add_argument(
        "--wind", action="store_true", help="in 8 m/s wind with moderate turbulence and gusts"
    )
    args = parser.parse_args(argv)
    frames = tuple(args.frame.split(","))
    if not args.profile:
        parser.print_help()
        return
    wind = (
        WindConfig(8.0, 270.0, turbulence_w20_m_s=15.4, gust_peak_m_s=3.0, gust_interval_s=5.0)
        if args.wind
        else None
    )
    print(f"{'N':>3} {'step us':>9} {'step+poll us':>13} {'pybullet us':>12} {'x real time':>12}")
    for n in (1, 10):
        airframe = frames if len(frames) == 1 else tuple(frames[i % len(frames)] for i in range(n))
        r = profile(n, args.steps, airframe=airframe, wind=wind)
        speed = 1e6 / (r["step+poll"] * WorldConfig().physics_hz)
        print(
            f"{n:>3} {r['step']:>9.1f} {r['step+poll']:>13.1f} {r['pybullet']:>12.1f} "
            f"{speed:>12.0f}"
        )
    print(
        f"(hover at {'100 m in wind' if wind else '10 m'}, 500 Hz physics; 'x real time' counts "
        "the simulator alone)"
    )


if __name__ == "__main__":
    _main()
