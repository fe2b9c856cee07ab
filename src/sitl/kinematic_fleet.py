"""Point-mass vehicles for the swarm-scale engine, vectorised over N (seed 000, Eqs. 19-20).

Each vehicle holds a horizontal speed ``V`` and course ``theta`` and moves
``x += V cos(theta) dt``, ``y += V sin(theta) dt`` (Eq. (20), seed 000) with its airframe's limits
(``sitl.vehicles.kinematics``): the speed follows its setpoint at most ``max_accel`` per second,
the course turns toward the next waypoint at most ``min(max_turn_rate, max_accel / V)`` (the
lateral acceleration a turn at speed V needs), and a vehicle facing away from its waypoint slows
down first (setpoint ``V cos(error)``), turning on the spot below ``HOVER_SPEED_M_S`` as a
multicopter does. It slows to stop at its last waypoint (``sqrt(2 a d)``). Height follows its
setpoint within the climb and descent rates and the vertical acceleration limit.

Each vehicle flies a path: waypoints (ENU, m) held in one padded (N, L, 3) array; a waypoint
closer than ``acceptance_m`` horizontally (and within 1 m in height) is passed and the next one
taken, as PX4 passes a fly-through mission item. Every operation is one numpy call over the fleet.

Or a vehicle holds a velocity (``set_velocity``, an offboard velocity setpoint): its course turns
toward the setpoint's direction and its speed follows the setpoint's horizontal speed (capped by
``max_speed``) with the same limits, and its climb rate the setpoint's vertical speed (clipped to
the climb and descent rates), until another command. ``velocity_mode`` says which vehicles do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sitl.vehicles.kinematics import KinematicLimits

HOVER_SPEED_M_S = 0.5
"""Below this horizontal speed a vehicle turns its course freely (it hovers)."""
HEIGHT_TOLERANCE_M = 1.0
"""A waypoint counts as reached only within this height of it, m."""
LANDED_HEIGHT_M = 0.05
"""A landing vehicle this close to its ground height has touched down, m."""


@dataclass
class FleetState:
    """The true state of every vehicle, world ENU, SI units."""

    position_m: np.ndarray
    """(N, 3) east, north, up, m."""
    speed_m_s: np.ndarray
    """(N,) horizontal speed, m/s."""
    course_rad: np.ndarray
    """(N,) direction of the horizontal velocity, counter-clockwise from east, rad."""
    climb_m_s: np.ndarray
    """(N,) vertical speed, up positive, m/s."""
    airborne: np.ndarray
    """(N,) bool: off the ground."""

    @property
    def velocity_m_s(self) -> np.ndarray:
        """(N, 3) ENU velocity, m/s."""
        return np.column_stack(
            (
                self.speed_m_s * np.cos(self.course_rad),
                self.speed_m_s * np.sin(self.course_rad),
                self.climb_m_s,
            )
        )


class KinematicFleet:
    """N point-mass multicopters following waypoint paths.

    Args:
        start_enu_m: (N, 3) resting points (east, north, ground height), m.
        limits: one :class:`KinematicLimits` per vehicle (or one for all).
        acceptance_m: horizontal radius within which a waypoint is passed, m.
    """

    def __init__(
        self,
        start_enu_m: np.ndarray,
        limits: Sequence[KinematicLimits] | KinematicLimits,
        acceptance_m: float = 2.0,
    ) -> None:
        start = np.asarray(start_enu_m, dtype=float).reshape(-1, 3)
        n = len(start)
        if isinstance(limits, KinematicLimits):
            limits = [limits] * n
        if len(limits) != n:
            raise ValueError(f"limits: one per vehicle ({n}), got {len(limits)}")
        if not acceptance_m > 0:
            raise ValueError(f"acceptance_m must be > 0, got {acceptance_m!r}")
        self.n = n
        self.acceptance_m = float(acceptance_m)
        self.ground_m = start[:, 2].copy()
        self.state = FleetState(
            position_m=start.copy(),
            speed_m_s=np.zeros(n),
            course_rad=np.zeros(n),
            climb_m_s=np.zeros(n),
            airborne=np.zeros(n, dtype=bool),
        )

        def column(name: str) -> np.ndarray:
            return np.array([getattr(lim, name) for lim in limits], dtype=float)

        self.max_speed = column("max_speed_m_s")
        self.max_accel = column("max_accel_m_s2")
        self.max_turn = np.radians(column("max_turn_rate_deg_s"))
        self.max_climb = column("max_climb_m_s")
        self.max_descent = column("max_descent_m_s")
        self.max_vaccel = column("max_vertical_accel_m_s2")
        self.cruise_m_s = self.max_speed.copy()
        """(N,) speed setpoint along the path, m/s (capped by ``max_speed``)."""
        self.climb_rate_m_s = self.max_climb.copy()
        """(N,) climb-rate setpoint, m/s (capped by ``max_climb``)."""
        self.paths = start[:, None, :].copy()
        """(N, L, 3) waypoints; rows shorter than L repeat their last waypoint."""
        self.path_len = np.ones(n, dtype=int)
        self.index = np.zeros(n, dtype=int)
        """(N,) index of the waypoint each vehicle flies to."""
        self.active = np.zeros(n, dtype=bool)
        """(N,) bool: the vehicle is flying its path (else it holds or rests)."""
        self.landing = np.zeros(n, dtype=bool)
        self.velocity_mode = np.zeros(n, dtype=bool)
        """(N,) bool: the vehicle holds ``velocity_set`` instead of flying its path."""
        self.velocity_set = np.zeros((n, 3))
        """(N, 3) ENU velocity setpoint of the vehicles in velocity mode, m/s."""
        self.distance_m = np.zeros(n)
        """(N,) horizontal and vertical distance flown, m."""
        self.airborne_s = np.zeros(n)
        """(N,) time spent off the ground, s."""
        self.max_tilt_rad = np.zeros(n)
        """(N,) largest tilt the accelerations needed (atan(a_h / g)), rad."""
        self._rows = np.arange(n)

    # -- commands (per vehicle) --------------------------------------------------------------

    def set_path(
        self, i: int, waypoints_enu_m: np.ndarray, cruise_m_s: float | None = None
    ) -> None:
        """Fly vehicle ``i`` through ``waypoints_enu_m`` ((K, 3), K >= 1), stopping at the last."""
        wp = np.asarray(waypoints_enu_m, dtype=float).reshape(-1, 3)
        if len(wp) == 0 or not np.isfinite(wp).all():
            raise ValueError(f"vehicle {i}: a path needs finite waypoints, got {len(wp)}")
        if len(wp) > self.paths.shape[1]:
            pad = np.repeat(self.paths[:, -1:, :], len(wp) - self.paths.shape[1], axis=1)
            self.paths = np.concatenate((self.paths, pad), axis=1)
        self.paths[i, : len(wp)] = wp
        self.paths[i, len(wp) :] = wp[-1]
        self.path_len[i] = len(wp)
        self.index[i] = 0
        self.active[i] = True
        self.landing[i] = False
        self.velocity_mode[i] = False
        if cruise_m_s is not None:
            self.cruise_m_s[i] = min(float(cruise_m_s), self.max_speed[i])

    def set_velocity(self, i: int, velocity_enu_m_s: np.ndarray) -> None:
        """Vehicle ``i`` holds ``velocity_enu_m_s`` (ENU, m/s) within its limits until told else.

        The horizontal part is scaled down to ``max_speed``; the vertical part is clipped to the
        climb and descent limits. A vehicle on the ground stays there (take off first).
        """
        v = np.asarray(velocity_enu_m_s, dtype=float).reshape(3)
        if not np.isfinite(v).all():
            raise ValueError(f"vehicle {i}: a velocity setpoint must be finite, got {v}")
        h = float(np.hypot(v[0], v[1]))
        if h > self.max_speed[i]:
            v[:2] *= self.max_speed[i] / h
        v[2] = min(max(v[2], -self.max_descent[i]), self.max_climb[i])
        self.velocity_set[i] = v
        self.velocity_mode[i] = True
        self.active[i] = True
        self.landing[i] = False

    def takeoff(self, i: int, height_m: float, climb_m_s: float | None = None) -> None:
        """Climb straight up to ``height_m`` above the vehicle's ground."""
        here = self.state.position_m[i]
        self.state.airborne[i] = True
        if climb_m_s is not None:
            self.climb_rate_m_s[i] = min(float(climb_m_s), self.max_climb[i])
        self.set_path(i, np.array([[here[0], here[1], self.ground_m[i] + float(height_m)]]))

    def land(self, i: int) -> None:
        """Descend where the vehicle is and touch down."""
        here = self.state.position_m[i]
        self.set_path(i, np.array([[here[0], here[1], self.ground_m[i]]]))
        self.landing[i] = True

    def crash(self, i: int) -> None:
        """Motors off: the vehicle lies on its ground below where it was, and stays there.

        The fall itself (about a second from a few metres) is not modelled.
        """
        s = self.state
        s.position_m[i, 2] = self.ground_m[i]
        s.speed_m_s[i] = 0.0
        s.climb_m_s[i] = 0.0
        s.airborne[i] = False
        self.active[i] = False
        self.landing[i] = False
        self.velocity_mode[i] = False

    # -- queries -----------------------------------------------------------------------------

    def path_done(self) -> np.ndarray:
        """(N,) bool: at its last waypoint, or not flying (False while holding a velocity)."""
        s = self.state
        last = self.paths[self._rows, self.path_len - 1]
        d = np.hypot(*(last[:, :2] - s.position_m[:, :2]).T)
        return (~self.active) | (
            ~self.velocity_mode
            & (self.index >= self.path_len - 1)
            & (d < self.acceptance_m)
            & (np.abs(last[:, 2] - s.position_m[:, 2]) < HEIGHT_TOLERANCE_M)
        )

    # -- dynamics ----------------------------------------------------------------------------

    def step(self, dt_s: float) -> None:
        """Advance every vehicle by ``dt_s`` seconds (Eq. (20), seed 000, with the limits)."""
        s = self.state
        pos = s.position_m
        fly = self.active & s.airborne
        vel = self.velocity_mode
        target = self.paths[self._rows, self.index]
        delta = target - pos
        dist_xy = np.hypot(delta[:, 0], delta[:, 1])
        # pass fly-through waypoints (one per step is enough at the engine's step rates)
        passed = (
            fly
            & ~vel
            & (dist_xy < self.acceptance_m)
            & (np.abs(delta[:, 2]) < HEIGHT_TOLERANCE_M)
            & (self.index < self.path_len - 1)
        )
        if passed.any():
            self.index[passed] += 1
            target = self.paths[self._rows, self.index]
            delta = target - pos
            dist_xy = np.hypot(delta[:, 0], delta[:, 1])
        last = (self.index >= self.path_len - 1) & ~vel
        # course toward the waypoint, turn-rate limited (Eq. (19): theta = atan(dy / dx)); in
        # velocity mode toward the setpoint's direction
        vset = self.velocity_set
        wanted = np.where(
            vel, np.arctan2(vset[:, 1], vset[:, 0]), np.arctan2(delta[:, 1], delta[:, 0])
        )
        error = (wanted - s.course_rad + np.pi) % (2.0 * np.pi) - np.pi
        turn = np.minimum(self.max_turn, self.max_accel / np.maximum(s.speed_m_s, 1e-6)) * dt_s
        hovering = s.speed_m_s < HOVER_SPEED_M_S
        step_turn = np.where(hovering, error, np.clip(error, -turn, turn))
        v_hold = np.hypot(vset[:, 0], vset[:, 1])
        far = np.where(vel, v_hold > 1e-3, dist_xy > 1e-3)
        s.course_rad = np.where(far & fly, s.course_rad + step_turn, s.course_rad)
        # speed: the cruise setpoint, less when facing away, stopping at the last waypoint
        v_set = np.where(vel, v_hold, self.cruise_m_s) * np.maximum(np.cos(error), 0.0)
        half = 0.5 * self.max_accel * dt_s  # the speed that stops in d at max_accel, per step
        v_stop = np.sqrt(half * half + 2.0 * self.max_accel * dist_xy) - half
        v_set = np.where(last, np.minimum(v_set, v_stop), v_set)
        v_set = np.where(fly & far, v_set, 0.0)
        dv = np.clip(v_set - s.speed_m_s, -self.max_accel * dt_s, self.max_accel * dt_s)
        speed_before = s.speed_m_s
        s.speed_m_s = np.maximum(speed_before + dv, 0.0)
        # never overshoot the last waypoint in one step
        step_len = s.speed_m_s * dt_s
        s.speed_m_s = np.where(last & (step_len > dist_xy), dist_xy / dt_s, s.speed_m_s)
        # height: rate-limited toward the waypoint's, with the vertical acceleration limit
        dz = np.where(fly, delta[:, 2], 0.0)
        w_cap = np.where(dz >= 0.0, self.climb_rate_m_s, self.max_descent)
        w_stop = np.sqrt(2.0 * self.max_vaccel * np.abs(dz))
        w_set = np.sign(dz) * np.minimum(w_cap, w_stop)
        w_set = np.where(vel & fly, vset[:, 2], w_set)
        dw = np.clip(w_set - s.climb_m_s, -self.max_vaccel * dt_s, self.max_vaccel * dt_s)
        s.climb_m_s = s.climb_m_s + dw
        overshoot = ~vel & (np.abs(s.climb_m_s * dt_s) > np.abs(dz))
        s.climb_m_s = np.where(overshoot, dz / dt_s, s.climb_m_s)
        # move (Eq. (20))
        vx = s.speed_m_s * np.cos(s.course_rad)
        vy = s.speed_m_s * np.sin(s.course_rad)
        moved = np.column_stack((vx, vy, s.climb_m_s)) * dt_s
        pos += moved
        self.distance_m += np.linalg.norm(moved, axis=1)
        # tilt a multicopter needs for this step's horizontal acceleration
        a_along = (s.speed_m_s - speed_before) / dt_s
        a_lateral = s.speed_m_s * np.abs(step_turn) / dt_s * (~hovering)
        tilt = np.arctan(np.hypot(a_along, a_lateral) / 9.80665)
        np.maximum(self.max_tilt_rad, np.where(s.airborne, tilt, 0.0), out=self.max_tilt_rad)
        self.airborne_s += np.where(s.airborne, dt_s, 0.0)
        # touch-down
        down = self.landing & (pos[:, 2] - self.ground_m < LANDED_HEIGHT_M)
        if down.any():
            pos[down, 2] = self.ground_m[down]
            s.airborne[down] = False
            s.speed_m_s[down] = 0.0
            s.climb_m_s[down] = 0.0
            self.active[down] = False
            self.landing[down] = False
