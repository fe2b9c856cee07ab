"""Aerodynamic drag of a multirotor, and the steady level-flight speed it implies.

Two documented terms, both in body axes (FLU):

- rotor drag, as PX4's Gazebo motor plugin (``gazebo_motor_model.cpp``, after Martin and Salaun
  2010, "The true role of accelerometer feedback in quadrotor control"): every rotor adds
  ``-c_rd * w * v_perp``, with ``w`` its speed and ``v_perp`` the airspeed in the rotor plane
  (computed in :mod:`sitl.physics.rotors`);
- parasite (fuselage) drag, the quadratic drag of a bluff body per body axis,
  ``F_j = -1/2 rho (Cd A)_j v_j |v_j|`` (e.g. Hoerner, "Fluid-Dynamic Drag", 1965, ch. 3): the
  ``drag_area_m2`` triple of the airframe YAML holds ``(Cd A)_x, (Cd A)_y, (Cd A)_z``.

:func:`level_flight_speed_m_s` solves the steady level flight of this model in closed form up to a
scalar root: with the body pitched by ``theta`` and flying level at ``v``, the body-axis balance of
weight ``W``, thrust ``T`` (along body z) and drag is

    D_x(v) = W sin(theta),   T = W cos(theta) + D_z(v),

with ``D_x = c_rd * sum(w) * v cos(theta) + 1/2 rho (Cd A)_x (v cos(theta))^2``,
``D_z = 1/2 rho (Cd A)_z (v sin(theta))^2`` and equal rotor speeds ``w = sqrt(T / (n k_f))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sitl.physics.earth import GRAVITY_M_S2

AIR_DENSITY_KG_M3 = 1.225
"""ISA sea-level air density, kg/m^3 (ICAO Doc 7488); the drag areas are identified with it."""


@dataclass(frozen=True)
class FuselageDrag:
    """Quadratic parasite drag of the airframe per body axis."""

    drag_area_m2: tuple[float, float, float]
    """Drag area Cd*A along body x (forward), y (left), z (up), m^2."""

    def __post_init__(self) -> None:
        area = tuple(float(a) for a in self.drag_area_m2)
        if len(area) != 3 or not all(a >= 0.0 for a in area):
            raise ValueError(f"drag_area_m2 needs three non-negative areas, got {area!r}")
        object.__setattr__(self, "drag_area_m2", area)

    def coefficients_n_s2_m2(self, air_density_kg_m3: float = AIR_DENSITY_KG_M3) -> tuple:
        """``1/2 rho (Cd A)_j`` per body axis, N/(m/s)^2."""
        return tuple(0.5 * air_density_kg_m3 * a for a in self.drag_area_m2)


@dataclass(frozen=True)
class LevelFlight:
    """Steady level flight at a fixed tilt (see the module equations)."""

    tilt_rad: float
    """Pitch of the body from level, rad."""
    speed_m_s: float
    """Horizontal speed, m/s."""
    thrust_n: float
    """Total rotor thrust, N."""
    rotor_speed_rad_s: float
    """Speed of every rotor (all equal), rad/s."""


def level_flight_speed_m_s(
    tilt_rad: float,
    mass_kg: float,
    n_rotors: int,
    thrust_coefficient_n_s2_rad2: float,
    rotor_drag_coefficient_n_s_m_rad: float,
    fuselage: FuselageDrag,
    gravity_m_s2: float = GRAVITY_M_S2,
    air_density_kg_m3: float = AIR_DENSITY_KG_M3,
) -> LevelFlight:
    """Speed at which a multirotor tilted by ``tilt_rad`` (about body y) flies level and steady.

    Solves ``D_x(v) = W sin(theta)`` with ``T = W cos(theta) + D_z(v)`` by bisection (``D_x`` grows
    monotonically with ``v``). A pure function of the airframe constants.
    """
    if not 0.0 <= tilt_rad < math.pi / 2:
        raise ValueError(f"tilt must be in [0, 90) degrees, got {math.degrees(tilt_rad):.1f}")
    weight = mass_kg * gravity_m_s2
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    kx, _, kz = fuselage.coefficients_n_s2_m2(air_density_kg_m3)

    def thrust(v: float) -> float:
        return weight * c + kz * (v * s) ** 2

    def excess_drag(v: float) -> float:
        sum_w = math.sqrt(n_rotors * thrust(v) / thrust_coefficient_n_s2_rad2)
        vx = v * c
        return rotor_drag_coefficient_n_s_m_rad * sum_w * vx + kx * vx * vx - weight * s

    lo, hi = 0.0, 1.0
    while excess_drag(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
        if hi > 1e4:
            raise ValueError("no finite level-flight speed: the airframe has no horizontal drag")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if excess_drag(mid) < 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < 1e-12 * max(1.0, hi):
            break
    v = 0.5 * (lo + hi)
    t = thrust(v)
    return LevelFlight(tilt_rad, v, t, math.sqrt(t / (n_rotors * thrust_coefficient_n_s2_rad2)))
