"""The simulated world: N multirotors in PyBullet, stepped in lockstep, speaking PX4 HIL messages.

One ``World`` owns the simulation clock, the PyBullet scene, the rotors, the sensors, the power
system (LiPo packs) and one seeded random generator. Each ``step`` advances the physics by one
step; ``poll_sensors`` returns the HIL_SENSOR / HIL_GPS messages and ``poll_battery`` the
BATTERY_STATUS messages that are due at the current time (call them once after each step).

Profile the hot loop with ``python -m sitl.world --profile``.
"""

from __future__ import annotations

import argparse
import logging
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl import frames, hil
from sitl.clock import SimClock, rate_divisor
from sitl.physics.bullet import BulletScene
from sitl.physics.earth import isa_pressure_pa, isa_temperature_k, magnetic_field_ned_gauss
from sitl.physics.rotors import RotorModel
from sitl.power.loads import PayloadLoads
from sitl.power.propulsion import load_power_spec
from sitl.power.system import FleetPower
from sitl.sensors.baro import Barometer, BaroSample
from sitl.sensors.gps import Gps
from sitl.sensors.imu import Imu
from sitl.sensors.mag import Magnetometer
from sitl.truth import TruthState
from sitl.vehicles.multirotor import MultirotorSpec, available_airframes, load_airframe

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
    airframe: str = "typhoon_h480"
    """Airframe name, a folder of ``sitl/vehicles``."""
    spawn_altitude_m: float | None = None
    """None: spawn resting on the ground; else height of the centre of mass above ground, m."""
    mag_declination_deg: float = 2.6
    """Magnetic declination at the origin, degrees east of true north."""
    mag_inclination_deg: float = 63.4
    """Magnetic inclination at the origin, degrees below the horizontal."""
    mag_strength_gauss: float = 0.48
    """Strength of the Earth magnetic field at the origin, gauss."""
    battery_hz: float = 50.0
    """Rate of the power model update and of BATTERY_STATUS, Hz; divides physics_hz."""
    loads: tuple[PayloadLoads, ...] = (PayloadLoads(),)
    """Avionics and payload loads: one entry for every vehicle, or one per vehicle."""
    bench_supply: bool = False
    """Power the rotors from an ideal constant-voltage supply instead of the LiPo pack."""
    battery_soc: float = 1.0
    """State of charge of every pack at the start, 0..1."""

    def __post_init__(self) -> None:
        if isinstance(self.n_vehicles, bool) or not isinstance(self.n_vehicles, int):
            raise ValueError(f"n_vehicles must be an int, got {self.n_vehicles!r}")
        if self.n_vehicles < 1:
            raise ValueError(f"n_vehicles must be >= 1, got {self.n_vehicles}")
        if not self.physics_hz > 0.0:
            raise ValueError(f"physics_hz must be positive, got {self.physics_hz!r}")
        for name in ("imu_hz", "gps_hz", "baro_hz", "mag_hz", "battery_hz"):
            rate_divisor(self.physics_hz, getattr(self, name), name)
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
        if not self.mag_strength_gauss > 0.0:
            raise ValueError(f"mag_strength_gauss must be positive: {self.mag_strength_gauss}")
        known = available_airframes()
        if self.airframe not in known:
            raise ValueError(f"unknown airframe {self.airframe!r}; available: {', '.join(known)}")
        if not 0.0 <= self.battery_soc <= 1.0:
            raise ValueError(f"battery_soc must be in [0, 1], got {self.battery_soc!r}")
        if len(self.loads) not in (1, self.n_vehicles):
            raise ValueError(
                f"loads needs 1 or n_vehicles={self.n_vehicles} entries, got {len(self.loads)}"
            )


class World:
    """N multirotors of one airframe in a PyBullet DIRECT world, advanced in lockstep.

    Vehicle i spawns at ENU (i * spacing_m, 0, h), facing north, with h the resting height of the
    centre of mass (or ``spawn_altitude_m``). Commands arrive as HIL_ACTUATOR_CONTROLS (controls in
    [0, 1] in the airframe's output order; zero unless the mode has SAFETY_ARMED); sensors leave as
    HIL_SENSOR and HIL_GPS.
    """

    def __init__(self, config: WorldConfig) -> None:
        self.config = config
        self.airframe: MultirotorSpec = load_airframe(config.airframe)
        spec = self.airframe
        n = config.n_vehicles
        self.n_vehicles = n
        self._clock = SimClock(config.physics_hz)
        dt = self._clock.dt_s
        self._imu_div = rate_divisor(config.physics_hz, config.imu_hz, "imu_hz")
        self._gps_div = rate_divisor(config.physics_hz, config.gps_hz, "gps_hz")
        self._baro_div = rate_divisor(config.physics_hz, config.baro_hz, "baro_hz")
        self._mag_div = rate_divisor(config.physics_hz, config.mag_hz, "mag_hz")
        self.origin = frames.GeodeticOrigin(
            config.origin_lat_deg, config.origin_lon_deg, config.origin_alt_amsl_m
        )

        height = spec.ground_clearance_m
        if config.spawn_altitude_m is not None:
            if config.spawn_altitude_m < height:
                raise ValueError(
                    f"spawn_altitude_m={config.spawn_altitude_m} m is below the resting height "
                    f"{height:.3f} m of {spec.name}'s centre of mass"
                )
            height = float(config.spawn_altitude_m)
        self._spawn_enu = np.array([[i * config.spacing_m, 0.0, height] for i in range(n)])
        facing_north = frames.quat_ned_frd_to_enu_flu(frames.quat_from_euler_ned_frd(0, 0, 0))
        self._scene = BulletScene(spec.urdf_path, self._spawn_enu, tuple(facing_north), dt)

        self._rotors = RotorModel(spec.motor, spec.rotors, spec.fuselage_drag_n_s_m, n, dt)
        self._controls = np.zeros((n, len(spec.rotors)))
        self._zeros = np.zeros_like(self._controls)
        self._ones = np.ones_like(self._controls)
        self._max_speed_rad_s = np.full_like(self._controls, spec.motor.max_speed_rad_s)
        self._nan_logged = False

        self._power_div = rate_divisor(config.physics_hz, config.battery_hz, "battery_hz")
        loads = config.loads * n if len(config.loads) == 1 else config.loads
        alt = np.array(config.origin_alt_amsl_m)
        air_density = float(isa_pressure_pa(alt) / (287.05 * isa_temperature_k(alt)))
        self.power = FleetPower(
            load_power_spec(spec.yaml_path),
            spec.motor.thrust_coefficient_n_s2_rad2,
            spec.motor.max_speed_rad_s,
            len(spec.rotors),
            air_density,
            loads,
            config.bench_supply,
            config.battery_soc,
        )
        """Electrical state of every vehicle (packs, power, rotor speed limit)."""
        self._battery_due = True
        self._apply_speed_limit()

        # Sensor construction order fixes the order of random draws: keep it.
        rng = np.random.default_rng(config.seed)
        field = magnetic_field_ned_gauss(
            config.mag_declination_deg, config.mag_inclination_deg, config.mag_strength_gauss
        )
        self._imu = Imu(spec.imu, n, rng)
        self._mag = Magnetometer(spec.mag, field, n, rng)
        self._baro = Barometer(spec.baro, n, rng)
        self._gps = Gps(spec.gps, self.origin, n, rng)

        self._last_poll_tick = -1
        self._last_tick = {"imu": -1, "mag": -1, "baro": -1, "gps": -1}
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
        wrench = self._rotors.body_wrench(scene.velocity_flu_m_s)
        scene.apply_body_wrench_and_step(wrench)
        self._rotors.advance()
        self._clock.advance()
        if self._clock.tick % self._power_div == 0:
            self.power.update(self._rotors.speed_rad_s, self._power_div * self._clock.dt_s)
            self._apply_speed_limit()
            self._battery_due = True

    def _apply_speed_limit(self) -> None:
        """Rotor speed at full command from the supply voltage; re-scale the commands."""
        limit = self.airframe.motor.max_speed_rad_s * self.power.speed_scale
        np.multiply(self._ones, limit[:, None], out=self._max_speed_rad_s)
        np.multiply(self._controls, self._max_speed_rad_s, out=self._rotors.command_rad_s)

    def _update_rotor_commands(self, nan_seen: bool) -> None:
        if nan_seen and not self._nan_logged:
            log.warning("NaN motor command received; treating it as 0 (logged once per world)")
            self._nan_logged = True
        u = self._controls
        np.fmax(u, self._zeros, out=u)  # fmax turns NaN into 0
        np.fmin(u, self._ones, out=u)
        np.multiply(u, self._max_speed_rad_s, out=self._rotors.command_rad_s)

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
        after they fall due). HIL_GPS is due every ``physics_hz / gps_hz`` steps. A second call at
        the same time returns ``(None, None)``.
        """
        tick = self._clock.tick
        if tick == self._last_poll_tick:
            return None, None
        self._last_poll_tick = tick
        sensors = self._sample_hil_sensor(tick) if tick % self._imu_div == 0 else None
        gps = self._sample_hil_gps(tick) if tick % self._gps_div == 0 else None
        return sensors, gps

    def poll_battery(self) -> list[mavlink2.MAVLink_battery_status_message] | None:
        """BATTERY_STATUS per vehicle (power module: voltage, current) when due, else None.

        Due at ``battery_hz`` (and at the start); a second call at the same time returns None.
        """
        if not self._battery_due:
            return None
        self._battery_due = False
        return hil.battery_status_messages(self.power.voltage_v, self.power.current_a)

    def _interval_s(self, sensor: str, tick: int, divisor: int) -> float:
        """Time since the sensor's previous sample (its nominal period for the first one)."""
        last = self._last_tick[sensor]
        self._last_tick[sensor] = tick
        return (tick - last if last >= 0 else divisor) * self._clock.dt_s

    def _sample_hil_sensor(self, tick: int) -> list[mavlink2.MAVLink_hil_sensor_message]:
        scene = self._scene
        self._imu.sample(
            scene.rotation,
            scene.velocity_enu_m_s,
            scene.angular_velocity_enu_rad_s,
            self._interval_s("imu", tick, self._imu_div),
            out=self._imu_frd,
        )
        fields = hil.FIELDS_IMU
        if tick >= self._next_mag_tick:
            dt = self._interval_s("mag", tick, self._mag_div)
            self._mag.sample(scene.rotation, dt, out=self._mag_frd)
            self._next_mag_tick = (tick // self._mag_div + 1) * self._mag_div
            fields |= hil.FIELDS_MAG
        if tick >= self._next_baro_tick:
            dt = self._interval_s("baro", tick, self._baro_div)
            alt = self.origin.alt_amsl_m + scene.position_enu_m[:, 2]
            self._baro_sample = self._baro.sample(alt, dt)
            self._next_baro_tick = (tick // self._baro_div + 1) * self._baro_div
            fields |= hil.FIELDS_BARO
        assert self._baro_sample is not None  # due at tick 0
        return hil.hil_sensor_messages(
            self._clock.time_usec, self._imu_mag_frd, self._baro_sample, fields
        )

    def _sample_hil_gps(self, tick: int) -> list[mavlink2.MAVLink_hil_gps_message]:
        scene = self._scene
        dt = self._interval_s("gps", tick, self._gps_div)
        fix = self._gps.sample(scene.position_enu_m, scene.velocity_enu_m_s, dt)
        p = self._gps.params
        return hil.hil_gps_messages(
            self._clock.time_usec, fix, p.eph_m, p.epv_m, p.satellites_visible
        )

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
            rotor_speed_rad_s=self._rotors.speed_rad_s.copy(),
            electrical_power_w=self.power.rotor_power_of(self._rotors.speed_rad_s)
            + self.power.loads_w,
            battery_voltage_v=self.power.voltage_v.copy(),
            battery_current_a=self.power.current_a.copy(),
            battery_soc=self.power.pack.soc.copy(),
            tilt_rad=np.arccos(np.clip(rotation[:, 2, 2], -1.0, 1.0)),
            origin=self.origin,
        )

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


def hover_actuator_message(
    airframe: MultirotorSpec,
) -> mavlink2.MAVLink_hil_actuator_controls_message:
    """An armed HIL_ACTUATOR_CONTROLS commanding every rotor to the hover speed."""
    controls = [airframe.hover_command] * len(airframe.rotors) + [0.0] * (16 - len(airframe.rotors))
    return mavlink2.MAVLink_hil_actuator_controls_message(
        0, controls, mavlink2.MAV_MODE_FLAG_SAFETY_ARMED, 0
    )


def profile(n_vehicles: int, n_steps: int, airborne_steps: int = 1000) -> dict[str, float]:
    """Wall time per physics step, us (best 2 s chunk), with every rotor commanded to hover.

    Open-loop hover is unstable, so each measurement runs in fresh worlds spawned at 10 m for
    ``airborne_steps`` steps (2 s), before any vehicle could tip over and reach the ground.

    Returns:
        ``step``: ``World.step`` alone; ``step+poll``: with ``poll_sensors`` after each step;
        ``pybullet``: ``stepSimulation`` alone on the same bodies in free fall (the floor).
    """
    import pybullet as p  # only the profiler calls PyBullet directly

    def timed(poll: bool) -> float:
        # Best chunk (least disturbed by other processes), as timeit does.
        best, done = math.inf, 0
        while done < n_steps:
            with World(WorldConfig(n_vehicles=n_vehicles, spawn_altitude_m=10.0)) as world:
                actuators = [hover_actuator_message(world.airframe)] * n_vehicles
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
    with World(WorldConfig(n_vehicles=n_vehicles, spawn_altitude_m=1000.0)) as world:
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
    args = parser.parse_args(argv)
    if not args.profile:
        parser.print_help()
        return
    print(f"{'N':>3} {'step us':>9} {'step+poll us':>13} {'pybullet us':>12} {'x real time':>12}")
    for n in (1, 10):
        r = profile(n, args.steps)
        speed = 1e6 / (r["step+poll"] * WorldConfig().physics_hz)
        print(
            f"{n:>3} {r['step']:>9.1f} {r['step+poll']:>13.1f} {r['pybullet']:>12.1f} "
            f"{speed:>12.0f}"
        )
    print("(hover at 10 m, 500 Hz physics; 'x real time' counts the simulator alone)")


if __name__ == "__main__":
    _main()
