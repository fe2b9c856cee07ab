"""What a ``worlds`` world asks of a simulation run: scene, spawn points, wind, mocap, parameters.

``world_setup(world, n_vehicles)`` turns a built world into the pieces ``SimulationConfig`` takes
(``wind``, ``params``, and the scene and spawn points ``world_config`` puts into its ``world``), so
``swarmsitl up --world``, ``swarmsitl run`` and ``swarmsitl params dump`` set a world up the same
way. ``world_config`` is the one place a run's ``WorldConfig`` is built from a command's options.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import worlds
from sitl.physics.wind import WindConfig
from sitl.sensors.camera import CameraSpec
from sitl.sensors.gps import GpsOutages, GpsOutageWindow
from sitl.sensors.mocap import MocapParams
from sitl.world import WorldConfig
from worlds.launch import default_area, spawn_points
from worlds.model import XYZ

GPS_DENIED_MOCAP_HZ = 50.0
"""Motion-capture rate of a GPS-denied world, Hz (divides the 500 Hz physics; PX4's external
vision is commonly fed at 30-100 Hz)."""
EV_CTRL_POSITION_AND_YAW = 9
"""EKF2_EV_CTRL of a GPS-denied world: 1 (horizontal position) + 8 (yaw). The barometer stays
the height reference (indoors it holds height well; the emulator's estimator has no vision
height reference switch), and velocity comes from the fused positions."""
GUST_REFERENCE_HEIGHT_M = 6.096
"""Height at which a world's ``gust_std_m_s`` is matched to Dryden turbulence: 20 ft, where
MIL-F-8785C's W20 is defined."""


@dataclass(frozen=True)
class WorldSetup:
    """A world's contribution to a ``SimulationConfig`` (pass the fields on as they are)."""

    scene: worlds.World | None = None
    """The built world (its solids, people and spills become the simulator's scene)."""
    gps_outages: GpsOutages | None = None
    """GPS-denied worlds: no fix for the whole run; None: the receivers work."""
    wind: WindConfig | None = None
    """The world's wind (steady + Dryden turbulence), None: calm air."""
    params: dict[str, float] = field(default_factory=dict)
    """Autopilot parameters for every vehicle (GPS-denied: EKF2 external vision)."""
    spawn_enu_m: tuple[XYZ, ...] = ()
    """Each vehicle's resting point (east, north, surface_z), m."""
    mocap_hz: float = 0.0
    """Motion-capture rate, Hz; 0: none."""
    bridge: bool = False
    """True: each vehicle needs ``python -m companion.scripts.mocap_bridge`` to fly (its
    position comes only from motion capture through its companion)."""
    launch_area: str = ""
    """Name of the launch area the vehicles start from (``agent_starts``: one per vehicle)."""


def world_setup(
    world: worlds.World,
    n_vehicles: int,
    launch_area: str | None = None,
    spacing_m: float = 5.0,
    spawn_enu_m: tuple[XYZ, ...] | None = None,
) -> WorldSetup:
    """How to simulate ``world`` with ``n_vehicles``.

    Args:
        world: a built world (``worlds.build(worlds.load_world(path))``).
        n_vehicles: number of vehicles, >= 1.
        launch_area: name of the launch area the vehicles start in; None: one per vehicle when
            the world has ``agent_start_0`` .. ``agent_start_<n-1>`` (task maps), else
            ``worlds.launch.default_area``.
        spacing_m: least distance between vehicles inside the launch area, m.
        spawn_enu_m: the vehicles' start points when the caller placed them itself (a
            scenario's groups in several launch areas); None: placed here.

    Raises:
        ValueError: an unknown launch area (naming those there are), or one too small for the
            vehicles (naming it, its radius and n).
    """
    if isinstance(n_vehicles, bool) or not isinstance(n_vehicles, int) or n_vehicles < 1:
        raise ValueError(f"n_vehicles must be an int >= 1, got {n_vehicles!r}")
    if spawn_enu_m is None:
        spawn, area_name = _spawn(world, n_vehicles, launch_area, spacing_m)
    else:
        if len(spawn_enu_m) != n_vehicles:
            raise ValueError(f"spawn_enu_m: one point per vehicle ({n_vehicles})")
        spawn = tuple(tuple(float(c) for c in p) for p in spawn_enu_m)
        area_name = launch_area or ""
    params: dict[str, float] = {}
    mocap_hz = 0.0
    outages = None
    if world.gps_denied:
        mocap_hz = GPS_DENIED_MOCAP_HZ
        outages = GpsOutages(windows=(GpsOutageWindow(0.0, math.inf),))
        params = {
            "EKF2_EV_CTRL": float(EV_CTRL_POSITION_AND_YAW),
            "EKF2_EV_DELAY": MocapParams().latency_ms,
        }
    return WorldSetup(
        scene=world,
        gps_outages=outages,
        wind=wind_config(world.wind),
        params=params,
        spawn_enu_m=spawn,
        mocap_hz=mocap_hz,
        bridge=world.gps_denied,
        launch_area=area_name,
    )


def world_config(
    n_vehicles: int,
    setup: WorldSetup | None = None,
    *,
    spawn_enu_m: tuple[XYZ, ...] | None = None,
    rangefinders: bool = False,
    cameras: bool = False,
    camera: CameraSpec | tuple[CameraSpec | None, ...] | None = None,
    mocap_hz: float | None = None,
    gps_outages: GpsOutages | None = None,
    battery_capacity_mah: tuple[float | None, ...] | None = None,
) -> WorldConfig:
    """The world of a run: a world file's scene (``setup``) and the sensors a command asks for.

    Args:
        n_vehicles: number of vehicles, >= 1.
        setup: what a world file asks for (scene, spawn points, GNSS denial, motion capture);
            None: the plain field.
        spawn_enu_m: the vehicles' resting points, replacing the setup's (a scenario's groups).
        rangefinders: fly the airframes' rangefinders.
        cameras: render the airframes' cameras (or ``camera``).
        camera: with ``cameras``, the camera(s) replacing the airframes' own.
        mocap_hz: motion-capture rate, Hz, replacing the world's (``--mocap``); None: the
            world's (a GPS-denied world's 50 Hz, else off).
        gps_outages: GNSS outages replacing the world's; None: the world's.
        battery_capacity_mah: each vehicle's pack capacity, mAh (None entries, or None: the
            airframe's).

    The run's seed, rates, spacing, airframes and wind are ``SimulationConfig``'s own fields.
    """
    if setup is not None and spawn_enu_m is None:
        spawn_enu_m = setup.spawn_enu_m
    return WorldConfig(
        n_vehicles=n_vehicles,
        scene=setup.scene if setup is not None else None,
        spawn_enu_m=spawn_enu_m or None,
        rangefinders=rangefinders,
        cameras=cameras,
        camera=camera if cameras else None,
        mocap_hz=(setup.mocap_hz if setup is not None else 0.0) if mocap_hz is None else mocap_hz,
        gps_outages=gps_outages
        or (setup.gps_outages if setup is not None and setup.gps_outages else GpsOutages()),
        battery_capacity_mah=battery_capacity_mah,
    )


def _spawn(
    world: worlds.World, n: int, name: str | None, spacing_m: float
) -> tuple[tuple[XYZ, ...], str]:
    """Spawn points and the name of the launch area they are in."""
    if name is None:
        names = {area.name for area in world.launch_areas}
        if n > 1 and all(f"agent_start_{k}" in names for k in range(n)):
            starts = [world.launch_area(f"agent_start_{k}").center_enu_m for k in range(n)]
            return tuple(tuple(map(float, s)) for s in starts), "agent_starts"  # type: ignore[misc]
        area = default_area(world)
    else:
        try:
            area = world.launch_area(name)
        except KeyError as exc:
            raise ValueError(f"launch_area: {exc.args[0]}") from exc
    return tuple(spawn_points(area, n, spacing_m)), area.name


def wind_config(wind: worlds.Wind | None) -> WindConfig | None:
    """A world's wind hint as the simulator's wind: steady wind plus Dryden turbulence.

    The steady part is the hint's speed and from-direction. ``gust_std_m_s``, the standard
    deviation of the wind about its mean, becomes Dryden turbulence (not discrete gusts): a
    standard deviation describes continuous random variation, which is what the Dryden model's
    sigma_u is, whereas a "1 - cosine" gust is an event with a peak and an interval the hint does
    not give. W20 is chosen so that the horizontal sigma_u at 20 ft (``GUST_REFERENCE_HEIGHT_M``)
    equals the hint: sigma_u = 0.1 W20 / (0.177 + 0.000823 h_ft)^0.4 (MIL-F-8785C); higher up
    sigma_u falls towards 0.1 W20 as the specification says. None or a calm hint: calm air.
    """
    if wind is None or (wind.speed_m_s == 0.0 and wind.gust_std_m_s == 0.0):
        return None
    h_ft = GUST_REFERENCE_HEIGHT_M / 0.3048
    w20 = wind.gust_std_m_s * (0.177 + 0.000823 * h_ft) ** 0.4 / 0.1
    return WindConfig(
        speed_m_s=float(wind.speed_m_s),
        from_deg=float(wind.from_direction_deg) % 360.0,
        turbulence_w20_m_s=float(w20),
    )
