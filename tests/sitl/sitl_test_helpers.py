"""Shared helpers of the sitl tests (imported by basename; pytest puts this folder on sys.path)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from pymavlink.dialects.v20 import common as mavlink2

from sitl.physics.earth import GRAVITY_M_S2
from sitl.physics.rotors import Spin
from sitl.world import World, WorldConfig

ARMED = mavlink2.MAV_MODE_FLAG_SAFETY_ARMED


def actuator_message(
    controls: Sequence[float], armed: bool = True
) -> mavlink2.MAVLink_hil_actuator_controls_message:
    """HIL_ACTUATOR_CONTROLS with the given first controls (rest 0)."""
    padded = [float(c) for c in controls] + [0.0] * (16 - len(controls))
    return mavlink2.MAVLink_hil_actuator_controls_message(0, padded, ARMED if armed else 0, 0)


def make_world(**overrides: object) -> World:
    """A World with the default configuration except ``overrides``.

    The rotors run from an ideal bench supply (rotor speed = command x max_speed_rad_s, as in
    Gazebo) unless ``bench_supply=False``: these tests check the rigid-body and rotor physics;
    the pack and its voltage are tested in test_power.py.
    """
    overrides.setdefault("bench_supply", True)
    return World(WorldConfig(**overrides))


def run(world: World, seconds: float, actuators: list | None = None) -> None:
    """Step ``world`` for ``seconds`` with the same actuator entries every step."""
    steps = round(seconds * world.config.physics_hz)
    for _ in range(steps):
        world.step(actuators)


def collect(world: World, seconds: float, actuators: list | None = None) -> tuple[list, list]:
    """Step and poll for ``seconds``; return all HIL_SENSOR lists and HIL_GPS lists."""
    sensors, gps = [], []
    steps = round(seconds * world.config.physics_hz)
    for _ in range(steps):
        world.step(actuators)
        s, g = world.poll_sensors()
        if s is not None:
            sensors.append(s)
        if g is not None:
            gps.append(g)
    return sensors, gps


def sensor_array(sensors: list, vehicle: int, fields: Sequence[str]) -> np.ndarray:
    """(samples, len(fields)) array of HIL_SENSOR fields of one vehicle."""
    return np.array([[getattr(batch[vehicle], f) for f in fields] for batch in sensors])


def hover_trim(spec) -> np.ndarray:
    """Commands that carry the weight with zero torque: the minimum change from equal speeds.

    Body FRD, thrust ``-k_f w^2`` along z at hub ``r``: torque ``(-r_y T, r_x T, +-k_m w^2)``.
    """
    k_f = spec.motor.thrust_coefficient_n_s2_rad2
    k_m = spec.motor.moment_coefficient_m * k_f
    r = np.array([rotor.position_frd_m for rotor in spec.rotors])
    yaw = np.array([1.0 if rotor.spin is Spin.CCW else -1.0 for rotor in spec.rotors])
    effect = np.vstack([np.full(len(r), k_f), -r[:, 1] * k_f, r[:, 0] * k_f, yaw * k_m])
    target = np.array([spec.mass_kg * GRAVITY_M_S2, 0.0, 0.0, 0.0])
    w2 = np.full(len(r), spec.hover_speed_rad_s**2)
    w2 += np.linalg.pinv(effect) @ (target - effect @ w2)
    return np.sqrt(w2) / spec.motor.max_speed_rad_s
