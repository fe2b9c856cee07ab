"""Rotors of a whole fleet of multirotors: motor lag, thrust, yaw reaction, rotor drag.

The model is the one of PX4's Gazebo-classic motor plugin (``gazebo_motor_model.cpp``), written
for arrays of shape ``(N, n_rotors)`` so that one numpy call advances every vehicle:

- motor speed follows its command through a first-order lag whose time constant is
  ``time_constant_up_s`` when speeding up and ``time_constant_down_s`` when slowing down,
  discretised exactly: ``w += (1 - exp(-dt / tau)) * (w_cmd - w)``;
- thrust ``k_f w^2`` along body up, at the rotor hub;
- yaw reaction ``moment_coefficient_m * k_f w^2``: a CW rotor (seen from above) pushes the body
  counter-clockwise, i.e. about +z FLU;
- rotor drag ``-w * rotor_drag_coefficient * v_perp`` (v_perp: airspeed in the rotor plane),
  applied at the hub, and rolling moment ``-w * rolling_moment_coefficient * v_perp``;
- quadratic parasite drag ``-1/2 rho (Cd A)_j v_j |v_j|`` per body axis (not in the Gazebo model;
  see :mod:`sitl.physics.drag` and the airframe YAML).

Not modelled: PX4 Gazebo's ad-hoc thrust reduction with axial speed (its own comment says it "has to
be modelled better"), blade flapping, ground effect, wind. The airspeed of every rotor is taken as
the velocity of the centre of mass (the ``omega x r`` term is neglected).

Everything here is expressed in the body FLU frame, in which PyBullet integrates.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from sitl import frames
from sitl.physics.drag import AIR_DENSITY_KG_M3, FuselageDrag
from sitl.physics.rotor_kernel import wrench_and_advance


class Spin(StrEnum):
    """Turning direction of a rotor seen from above."""

    CW = "cw"
    CCW = "ccw"


@dataclass(frozen=True)
class MotorParams:
    """Parameters shared by every motor and propeller of an airframe."""

    thrust_coefficient_n_s2_rad2: float
    """Thrust per squared rotor speed k_f, N/(rad/s)^2 (Gazebo ``motorConstant``)."""
    moment_coefficient_m: float
    """Yaw reaction torque per unit thrust, m (Gazebo ``momentConstant``)."""
    max_speed_rad_s: float
    """Rotor speed at command 1, rad/s (Gazebo ``maxRotVelocity``)."""
    time_constant_up_s: float
    """First-order lag time constant while speeding up, s."""
    time_constant_down_s: float
    """First-order lag time constant while slowing down, s."""
    rotor_drag_coefficient_n_s_m_rad: float
    """In-plane rotor drag per rotor speed per airspeed, N/((rad/s)(m/s))."""
    rolling_moment_coefficient_n_s_rad: float
    """Rolling moment per rotor speed per in-plane airspeed, N m/((rad/s)(m/s))."""

    def __post_init__(self) -> None:
        for name in (
            "thrust_coefficient_n_s2_rad2",
            "max_speed_rad_s",
            "time_constant_up_s",
            "time_constant_down_s",
        ):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"motor {name} must be positive, got {getattr(self, name)!r}")


@dataclass(frozen=True)
class RotorSpec:
    """One rotor of a layout table."""

    output: int
    """Actuator output index (position in HIL_ACTUATOR_CONTROLS.controls)."""
    position_frd_m: tuple[float, float, float]
    """Hub position relative to the centre of mass, body FRD, m."""
    spin: Spin
    """Turning direction seen from above."""


class RotorModel:
    """Rotor speeds and the body wrench they produce, for N vehicles at once.

    The wrench is linear in the features ``[w_i^2, w_i v_j, v_j |v_j|]``, so one matrix product
    maps them all: ``wrench (N, 6) = features (N, 4 n + 3) @ wrench_map``.
    """

    def __init__(
        self,
        motor: MotorParams,
        rotors: tuple[RotorSpec, ...],
        fuselage: FuselageDrag,
        n_vehicles: int,
        dt_s: float,
        air_density_kg_m3: float = AIR_DENSITY_KG_M3,
    ) -> None:
        n_rot = len(rotors)
        self.motor = motor
        self.n_rotors = n_rot
        k_f = motor.thrust_coefficient_n_s2_rad2
        self.yaw_coefficient_n_m_s2_rad2 = motor.moment_coefficient_m * k_f
        """Yaw reaction torque per squared rotor speed k_m, N m/(rad/s)^2."""

        pos_flu = frames.frd_to_flu(np.array([r.position_frd_m for r in rotors]))
        spin_sign = np.array([1.0 if r.spin is Spin.CW else -1.0 for r in rotors])

        # Wrench [F_flu, tau_flu] per squared rotor speed: (n_rot, 6).
        thrust_map = np.zeros((n_rot, 6))
        thrust_map[:, 2] = k_f
        thrust_map[:, 3] = pos_flu[:, 1] * k_f
        thrust_map[:, 4] = -pos_flu[:, 0] * k_f
        thrust_map[:, 5] = spin_sign * self.yaw_coefficient_n_m_s2_rad2

        # Wrench (6) per unit rotor speed per unit body velocity component (3): (n_rot, 6, 3).
        in_plane = np.diag([1.0, 1.0, 0.0])
        c_d = motor.rotor_drag_coefficient_n_s_m_rad
        c_roll = motor.rolling_moment_coefficient_n_s_rad
        drag_map = np.zeros((n_rot, 6, 3))
        for i, r in enumerate(pos_flu):
            cross = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
            drag_map[i, :3] = -c_d * in_plane
            drag_map[i, 3:] = -c_d * cross @ in_plane - c_roll * in_plane
        drag_rows = drag_map.transpose(0, 2, 1).reshape(3 * n_rot, 6)
        # Wrench per v_j |v_j| (3): -1/2 rho (Cd A)_j on force axis j.
        parasite_rows = np.zeros((3, 6))
        parasite_rows[:, :3] = -np.diag(fuselage.coefficients_n_s2_m2(air_density_kg_m3))
        self._wrench_map = np.vstack([thrust_map, drag_rows, parasite_rows])

        self._alpha_up = float(-np.expm1(-dt_s / motor.time_constant_up_s))
        self._alpha_down = float(-np.expm1(-dt_s / motor.time_constant_down_s))

        # State and output buffers, allocated once (none in the hot loop).
        self.speed_rad_s = np.zeros((n_vehicles, n_rot))
        """Rotor speeds, rad/s, (N, n_rotors)."""
        self.command_rad_s = np.zeros((n_vehicles, n_rot))
        """Commanded rotor speeds, rad/s, (N, n_rotors); write into it."""
        self._wrench = np.zeros((n_vehicles, 6))

    def body_wrench(self, velocity_flu_m_s: np.ndarray) -> np.ndarray:
        """Force and torque on each body at the current rotor speeds, ``(N, 6)`` = [F_flu, tau_flu].

        Args:
            velocity_flu_m_s: velocity of each centre of mass relative to the air, in its body FLU
                frame, ``(N, 1, 3)``.

        Returns:
            A buffer owned by this object, overwritten by the next call.
        """
        wrench_and_advance(
            self.speed_rad_s,
            self.command_rad_s,
            velocity_flu_m_s,
            self._wrench_map,
            0.0,
            0.0,
            self._wrench,
        )
        return self._wrench

    def step(self, velocity_flu_m_s: np.ndarray) -> np.ndarray:
        """``body_wrench`` of the current speeds, then advance them one step (one compiled call).

        The speeds move towards their commands through the first-order motor lag.
        """
        wrench_and_advance(
            self.speed_rad_s,
            self.command_rad_s,
            velocity_flu_m_s,
            self._wrench_map,
            self._alpha_up,
            self._alpha_down,
            self._wrench,
        )
        return self._wrench
