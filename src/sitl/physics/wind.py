"""Wind at every vehicle: steady wind, Dryden turbulence and discrete "1 - cosine" gusts.

All arrays are shaped ``(N, ...)`` and advanced with one numpy call per operation for the fleet.
World frame ENU (x east, y north, z up), SI units; heights are above the flat ground (ENU z = 0).

**Steady wind.** ``speed_m_s`` blowing *from* ``from_deg`` (meteorological convention, degrees
clockwise from true north), so the air moves towards ``from_deg + 180``::

    w_east = -speed sin(from),   w_north = -speed cos(from),   w_up = up_m_s

It is the same at every height (no wind-shear profile).

**Dryden turbulence**, low-altitude form of MIL-F-8785C (1980, "Atmospheric disturbances",
continuous random turbulence, Dryden form; the same in MIL-HDBK-1797), with h the height in
feet clipped to [10, 1000] ft (the low-altitude range of the specification; 10 ft is the floor
MATLAB's Dryden block also uses):

    sigma_w = 0.1 W20,     sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4      (1)
    L_w = h,               L_u = L_v = h / (0.177 + 0.000823 h)^1.2                     (2)

W20 is the wind speed 6 m (20 ft) above ground; the specification's light / moderate / severe
turbulence has W20 = 15 / 30 / 45 kt. The components are aligned with the mean wind (u along the
direction the air moves, v to its left, w up), as the specification does at low altitude. Their
spatial spectra (Omega in rad/m) are::

    Phi_u = sigma_u^2 (2 L_u / pi) / (1 + (L_u Omega)^2)                              (3)
    Phi_v = sigma_v^2 (L_v / pi) (1 + 3 (L_v Omega)^2) / (1 + (L_v Omega)^2)^2        (4)

and Phi_w as Phi_v with (sigma_w, L_w).

A vehicle crosses the frozen field at V, the norm of its velocity relative to the mean wind
(Taylor's hypothesis, omega = V Omega), floored at ``min_airspeed_m_s`` so that a vehicle drifting
with the air still sees the field change. With T = L / V the temporal shaping filters (driven
by unit white noise) are

    H_u(s) = sigma_u sqrt(2 T) / (1 + T s)
    H_v(s) = sigma_v sqrt(T) (1 + sqrt(3) T s) / (1 + T s)^2          (same for w)

Both are realised with two unit-variance states per axis: y1, a first-order Gauss-Markov process
(autocorrelation exp(-|tau| / T)), and y2 = y1 / (1 + T s). Then u = sigma_u y1 and, since
(1 + sqrt(3) T s) / (1 + T s)^2 = sqrt(3) / (1 + T s) + (1 - sqrt(3)) / (1 + T s)^2,
v = sigma_v (sqrt(3) y1 + (1 - sqrt(3)) y2) / sqrt(2) (the stationary covariance of (y1, y2) is
P = [[1, 1/2], [1/2, 1/2]], which makes the bracket's variance 2). The states are discretised
exactly (the transition of the linear stochastic differential equation over one update of dt,
with a = exp(-dt / T)):

    [y1, y2]_{k+1} = [[a, 0], [a dt / T, a]] [y1, y2]_k + chol(Q) n_k,   Q = P - Phi P Phi^T,

n_k standard normal. Q keeps the covariance at P for any T, so the variance stays exact when T
changes with height and airspeed, and the state starts drawn from P (stationary from t = 0).
The wind is advanced at ``update_hz`` (default 100 Hz) and held between updates; sigma and T are
re-evaluated every ``COEFFICIENT_EVERY`` updates (Q stays consistent with the T in use, so the
variance stays exact). Turbulence and gusts together add about 6 us per 500 Hz physics step for
one vehicle, 9 us for ten (``python -m sitl.world --profile --wind``).

**Gusts**: the "1 - cosine" discrete gust model of MIL-F-8785C: over the distance x the
vehicle moves relative to the air after the gust front, the wind rises by
``(V_m / 2)(1 - cos(pi x / d_m))``; the specification holds V_m after x = d_m, here the gust falls
back symmetrically (a gust 2 d_m long, as the 1-cosine gust of EASA CS-25.341) so that gusts are
events, not steps. Onsets are a Poisson process per vehicle (exponential intervals of mean
``gust_interval_s``); a gust blows along the mean wind, or in a random horizontal direction when
there is no steady wind.

**Random draws** come from a ``numpy.random.Generator`` the world derives from its own after the
sensors (see ``World``). Order: at construction the turbulence state (N, 3, 2) then, with gusts,
the first onset delays (N,); at each update the turbulence noise (2, N, 3), then for the vehicles
whose gust starts the next delays (and, without steady wind, their directions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

FEET_PER_M = 1.0 / 0.3048
"""Feet per metre (international foot)."""
KNOT_M_S = 1852.0 / 3600.0
"""One knot, m/s."""
TURBULENCE_W20_M_S = {
    "light": 15.0 * KNOT_M_S,
    "moderate": 30.0 * KNOT_M_S,
    "severe": 45.0 * KNOT_M_S,
}
"""W20 (wind 20 ft above ground) of MIL-F-8785C's low-altitude turbulence intensities, m/s."""
COEFFICIENT_EVERY = 10
"""The turbulence intensities and time constants (functions of height and airspeed, which change
slowly) are recomputed every this many updates, 0.1 s at 100 Hz; the states advance every update."""
_H_MIN_FT = 10.0
_H_MAX_FT = 1000.0
_SQRT3 = math.sqrt(3.0)


@dataclass(frozen=True)
class WindConfig:
    """Wind of a world; validated on construction (``ValueError`` naming the field)."""

    speed_m_s: float = 0.0
    """Steady horizontal wind speed, m/s, >= 0."""
    from_deg: float = 0.0
    """Direction the steady wind blows from, degrees clockwise from true north, [0, 360)."""
    up_m_s: float = 0.0
    """Steady vertical wind, m/s, positive up."""
    turbulence_w20_m_s: float = 0.0
    """W20 of the Dryden turbulence (wind speed 6 m above ground), m/s; 0: no turbulence.
    ``TURBULENCE_W20_M_S`` has MIL-F-8785C's light, moderate and severe values."""
    gust_peak_m_s: float = 0.0
    """Peak wind added by a discrete gust (V_m), m/s; 0: no gusts."""
    gust_length_m: float = 20.0
    """Distance over which a gust builds up (d_m), m; it dies down over as much again."""
    gust_interval_s: float = 30.0
    """Mean time between gust onsets at one vehicle, s (exponentially distributed)."""
    min_airspeed_m_s: float = 1.0
    """Floor of the speed at which a vehicle crosses the turbulence and gusts, m/s."""
    update_hz: float = 100.0
    """Rate at which turbulence and gusts are advanced (held in between), Hz; divides the
    physics rate."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"wind {f.name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"wind {f.name} must be finite, got {value!r}")
        for name in ("speed_m_s", "turbulence_w20_m_s", "gust_peak_m_s"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"wind {name} must be >= 0, got {getattr(self, name)!r}")
        for name in ("gust_length_m", "gust_interval_s", "min_airspeed_m_s", "update_hz"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"wind {name} must be positive, got {getattr(self, name)!r}")
        if not 0.0 <= self.from_deg < 360.0:
            raise ValueError(f"wind from_deg must be in [0, 360), got {self.from_deg!r}")

    @property
    def steady_enu_m_s(self) -> np.ndarray:
        """The steady wind velocity, ENU, m/s, (3,)."""
        a = math.radians(self.from_deg)
        return np.array([-self.speed_m_s * math.sin(a), -self.speed_m_s * math.cos(a), self.up_m_s])


class WindField:
    """The wind velocity at each of N vehicles; ``update`` advances turbulence and gusts."""

    def __init__(
        self, config: WindConfig, n_vehicles: int, dt_s: float, rng: np.random.Generator
    ) -> None:
        """Args: the configuration, fleet size, update period ``1 / update_hz`` (s), the rng."""
        self.config = config
        self.dt_s = float(dt_s)
        self._rng = rng
        n = n_vehicles
        self._steady = config.steady_enu_m_s
        self.velocity_enu_m_s = np.tile(self._steady, (n, 1))
        """Wind at each vehicle now, ENU, m/s, (N, 3) (a buffer updated in place)."""
        self.turbulence_enu_m_s = np.zeros((n, 3))
        """Turbulence part of the wind, ENU, m/s, (N, 3)."""
        self.gust_enu_m_s = np.zeros((n, 3))
        """Gust part of the wind, ENU, m/s, (N, 3)."""

        # Mean-wind axes (u along the air's motion, v to its left, w up) -> ENU, as rows:
        # turbulence_enu (N, 3) = uvw (N, 3) @ axes.
        a = math.radians(config.from_deg)
        along = np.array([-math.sin(a), -math.cos(a), 0.0])
        left = np.array([-along[1], along[0], 0.0])
        self._axes = np.array([along, left, [0.0, 0.0, 1.0]])

        self._rel = np.zeros((n, 3))
        self._speed = np.zeros(n)
        self._turbulent = config.turbulence_w20_m_s > 0.0
        if self._turbulent:
            # Unit-variance states (y1, y2) per axis, drawn from their stationary covariance P.
            z = rng.standard_normal((n, 3, 2))
            self._y1 = z[:, :, 0].copy()
            self._y2 = 0.5 * self._y1 + 0.5 * z[:, :, 1]
            self._c1 = np.array([1.0, _SQRT3 / math.sqrt(2.0), _SQRT3 / math.sqrt(2.0)])
            self._c2 = np.array(
                [0.0, (1.0 - _SQRT3) / math.sqrt(2.0), (1.0 - _SQRT3) / math.sqrt(2.0)]
            )
            self._noise = np.zeros((2, n, 3))
            self._sigma_w = 0.1 * config.turbulence_w20_m_s
            self._h_ft = np.zeros(n)
            self._d = np.zeros(n)
            self._coefficients = np.zeros((7, n, 3))  # sigma, r, a, b, l11, l21, l22
            self._coefficients[0, :, 2] = self._sigma_w  # sigma_w does not depend on height
            self._scratch = np.zeros((3, n, 3))
            self._updates = 0

        self._gusty = config.gust_peak_m_s > 0.0
        if self._gusty:
            self._gust_x_m = np.full(n, np.inf)  # distance into the current gust; inf: none
            self._gust_wait_s = rng.exponential(config.gust_interval_s, n)
            self._gust_dir = np.tile(along, (n, 1))

    def update(self, position_enu_m: np.ndarray, velocity_enu_m_s: np.ndarray) -> np.ndarray:
        """Advance turbulence and gusts by ``dt_s`` for vehicles at these positions/velocities.

        Args:
            position_enu_m: centre-of-mass positions, ENU, m, (N, 3).
            velocity_enu_m_s: centre-of-mass velocities, ENU, m/s, (N, 3).

        Returns:
            ``velocity_enu_m_s`` of the wind, (N, 3), the buffer of this object.
        """
        cfg = self.config
        if not (self._turbulent or self._gusty):
            return self.velocity_enu_m_s
        # Speed through the air mass (Taylor's frozen-field hypothesis), floored.
        rel = np.subtract(velocity_enu_m_s, self._steady, out=self._rel)
        speed = np.einsum("ij,ij->i", rel, rel, out=self._speed)
        np.sqrt(speed, out=speed)
        np.maximum(speed, cfg.min_airspeed_m_s, out=speed)
        if self._turbulent:
            self._advance_turbulence(position_enu_m[:, 2], speed)
        if self._gusty:
            self._advance_gusts(speed)
        np.add(self._steady, self.turbulence_enu_m_s, out=self.velocity_enu_m_s)
        np.add(self.velocity_enu_m_s, self.gust_enu_m_s, out=self.velocity_enu_m_s)
        return self.velocity_enu_m_s

    def _advance_turbulence(self, height_m: np.ndarray, speed_m_s: np.ndarray) -> None:
        """One exact step of the shaping filters (module docstring), in preallocated buffers."""
        if self._updates % COEFFICIENT_EVERY == 0:
            self._update_coefficients(height_m, speed_m_s)
        self._updates += 1
        sigma, _, a, b, l11, l21, l22 = self._coefficients
        tmp, noise1, noise2 = self._scratch
        n1, n2 = self._rng.standard_normal(out=self._noise)
        y1, y2 = self._y1, self._y2
        # y2 <- b y1 + a y2 + l21 n1 + l22 n2, then y1 <- a y1 + l11 n1.
        y2 *= a
        np.multiply(b, y1, out=tmp)
        y2 += tmp
        np.multiply(l21, n1, out=noise2)
        y2 += noise2
        np.multiply(l22, n2, out=noise2)
        y2 += noise2
        y1 *= a
        np.multiply(l11, n1, out=noise1)
        y1 += noise1
        # (u, v, w) = sigma (c1 y1 + c2 y2), then to ENU.
        np.multiply(self._c1, y1, out=tmp)
        np.multiply(self._c2, y2, out=noise1)
        tmp += noise1
        tmp *= sigma
        np.matmul(tmp, self._axes, out=self.turbulence_enu_m_s)

    def _update_coefficients(self, height_m: np.ndarray, speed_m_s: np.ndarray) -> None:
        """sigma, T and the transition Phi = [[a, 0], [b, a]] with chol(Q) at this height/speed."""
        sigma, r, a, b, l11, l21, l22 = self._coefficients
        tmp = self._scratch[0]
        # Eq. (1)-(2) with d = (0.177 + 0.000823 h)^0.4: sigma_uv = sigma_w / d, L_w = h,
        # L_uv = h / d^3; r = dt / T = dt V / L per axis.
        h_ft = np.multiply(height_m, FEET_PER_M, out=self._h_ft)
        np.clip(h_ft, _H_MIN_FT, _H_MAX_FT, out=h_ft)
        d = np.multiply(h_ft, 0.000823, out=self._d)
        d += 0.177
        np.power(d, 0.4, out=d)
        np.divide(self._sigma_w, d, out=sigma[:, 0])
        sigma[:, 1] = sigma[:, 0]
        np.divide(speed_m_s, h_ft, out=r[:, 2])
        r[:, 2] *= self.dt_s * FEET_PER_M
        np.power(d, 3.0, out=d)
        np.multiply(r[:, 2], d, out=r[:, 0])
        r[:, 1] = r[:, 0]
        # chol(Q), Q = P - Phi P Phi^T, P = [[1, 1/2], [1/2, 1/2]]:
        # q11 = 1 - a^2, q12 = q11 / 2 - a b, q22 = q12 - b^2.
        np.negative(r, out=a)
        np.exp(a, out=a)
        np.multiply(r, a, out=b)
        np.multiply(a, a, out=l11)
        np.subtract(1.0, l11, out=l11)  # q11
        np.multiply(a, b, out=tmp)
        np.multiply(l11, 0.5, out=l21)
        l21 -= tmp  # q12
        np.multiply(b, b, out=l22)
        np.subtract(l21, l22, out=l22)  # q22
        np.sqrt(l11, out=l11)
        l21 /= l11
        np.multiply(l21, l21, out=tmp)
        l22 -= tmp
        np.maximum(l22, 0.0, out=l22)
        np.sqrt(l22, out=l22)

    def _advance_gusts(self, speed_m_s: np.ndarray) -> None:
        cfg = self.config
        wait = self._gust_wait_s
        wait -= self.dt_s
        starting = wait <= 0.0
        if starting.any():
            k = int(starting.sum())
            self._gust_x_m[starting] = 0.0
            wait[starting] += self._rng.exponential(cfg.gust_interval_s, k)
            if cfg.speed_m_s == 0.0:
                azimuth = self._rng.uniform(0.0, 2.0 * math.pi, k)
                self._gust_dir[starting, 0] = np.cos(azimuth)
                self._gust_dir[starting, 1] = np.sin(azimuth)
        d = cfg.gust_length_m
        x = np.minimum(self._gust_x_m, 2.0 * d)  # past the gust (or none): 2 d, shape 0
        magnitude = 0.5 * cfg.gust_peak_m_s * (1.0 - np.cos(np.pi / d * x))
        np.multiply(magnitude[:, None], self._gust_dir, out=self.gust_enu_m_s)
        self._gust_x_m += speed_m_s * self.dt_s
