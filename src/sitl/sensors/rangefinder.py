"""Ultrasonic rangefinders: cones of rays cast in PyBullet, the nearest echo, noise and dropouts.

A sonar reports the time of flight of the first echo it hears: the distance to the nearest
surface inside its beam. Each sensor's beam is a cone of full angle ``beam_width_deg``, sampled by
a centre ray and :data:`RINGS` rings of :data:`RAYS_PER_RING` rays (the outer ring on the cone's
edge); the reading is the shortest hit over those rays, measured from the sensor's mount point
along the ray (a slant range). Then:

- out of range (nothing hit closer than ``max_range_m``, or nearer than ``min_range_m``): no echo;
- a random dropout (probability ``dropout_probability`` per reading): no echo;
- otherwise the range plus white Gaussian noise of ``noise_sigma_m + noise_per_m * range``.

Every vehicle's due rays go into one ``pybullet.rayTestBatch`` per sensor tick (split only above
PyBullet's batch limit). Rays that hit the vehicle carrying the sensor (e.g. a downward beam
crossing a landing skid) are cast again from just past that hit, so a vehicle never sees itself
(measured: a ray that starts inside a collision shape does not report it, so a mount on or inside
the fuselage needs no special case; the shipped mounts need no re-cast at all).

Frames: mounts and directions in body FRD (x forward, y right, z down), m, as MAVLink's
MAV_SENSOR_ROTATION describes them; the scene is ENU with body FLU axes (``sitl.frames``).

Models (presets a mount names with ``model``; every number can be overridden per sensor):

- ``hc_sr04``: HC-SR04 module, 2-400 cm "ranging accuracy up to 3 mm", measuring angle 15 deg,
  40 kHz, "over 60 ms measurement cycle" suggested (HC-SR04 user's manual, e.g. SparkFun
  SEN-15569; clones quote 2-450 cm and "not more than 15 degrees"). Range 0.02-4.5 m, beam 15 deg,
  20 Hz (the nearest rate to the 60 ms cycle that divides 500 Hz physics with margin), noise
  1 cm + 0.5 % of range (ASSUMED: the datasheet's 3 mm is a best case on a large flat target).
- ``mb1240``: MaxBotix XL-MaxSonar-EZ4 (MB1240): range readings 20-765 cm with 1 cm resolution,
  10 Hz free-run, analogue output limited to ~700 cm at 5 V (MaxBotix XL-MaxSonar-EZ/AE datasheet
  PD11840). Range 0.2-7.0 m, 10 Hz, beam 10 deg (ASSUMED from the EZ4's narrow beam plots),
  noise 1 cm + 0.5 % of range (ASSUMED).
Dropout probability 1 % for both (ASSUMED: missed echoes off soft or slanted surfaces).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields

import numpy as np

from sitl.clock import rate_divisor
from sitl.physics.bullet_import import pybullet as p

RINGS = 2
"""Rings of rays around the centre ray (the outer one on the cone's edge)."""
RAYS_PER_RING = 8
"""Rays per ring, evenly spaced around the axis (one in each body axis plane)."""
RAYS_PER_SENSOR = 1 + RINGS * RAYS_PER_RING
"""Rays that sample one sensor's cone."""
MAX_RAYS_PER_BATCH = getattr(p, "MAX_RAY_INTERSECTION_BATCH_SIZE", 16384)
"""PyBullet's limit of rays in one ``rayTestBatch``."""
RAY_THREADS = 0
"""``rayTestBatch``'s numThreads: 0 lets Bullet use all its worker threads."""
_SELF_HIT_STEP_M = 1e-4
"""How far past a hit on the vehicle's own body a ray is cast again, m."""
_MAX_RECASTS = 3

ORIENTATION_DIRECTIONS_FRD: Mapping[int, tuple[float, float, float]] = {
    **{
        k: (round(math.cos(k * math.pi / 4), 12), round(math.sin(k * math.pi / 4), 12), 0.0)
        for k in range(8)
    },
    24: (0.0, 0.0, -1.0),
    25: (0.0, 0.0, 1.0),
}
"""Pointing direction (body FRD unit vector) of each supported MAV_SENSOR_ROTATION: NONE (0,
forward), YAW_45 .. YAW_315 (1..7, clockwise seen from above), PITCH_90 (24, up) and PITCH_270
(25, down)."""

MAV_DISTANCE_SENSOR_ULTRASOUND = 1
"""MAV_DISTANCE_SENSOR type of a sonar."""


@dataclass(frozen=True)
class RangefinderSpec:
    """One rangefinder: its model's numbers and its mount on the airframe."""

    id: int
    """MAVLink DISTANCE_SENSOR id, 0..255, distinct per vehicle."""
    orientation: int
    """MAV_SENSOR_ROTATION of the beam axis (a key of :data:`ORIENTATION_DIRECTIONS_FRD`)."""
    position_frd_m: tuple[float, float, float]
    """Mount point relative to the centre of mass, body FRD, m."""
    model: str = "hc_sr04"
    """Name of the preset the numbers came from (see :data:`MODELS`)."""
    min_range_m: float = 0.02
    """Shortest range the sensor reports, m."""
    max_range_m: float = 4.5
    """Longest range the sensor reports, m."""
    beam_width_deg: float = 15.0
    """Full angle of the beam cone, degrees."""
    rate_hz: float = 20.0
    """Readings per second of simulation time, Hz (must divide the physics rate)."""
    noise_sigma_m: float = 0.01
    """Range-independent part of the 1-sigma noise, m."""
    noise_per_m: float = 0.005
    """Range-dependent part of the 1-sigma noise, m per m of range."""
    dropout_probability: float = 0.01
    """Probability that a reading has no echo although a surface is in range."""

    def __post_init__(self) -> None:
        if isinstance(self.id, bool) or not isinstance(self.id, int) or not 0 <= self.id <= 255:
            raise ValueError(f"id must be an integer 0..255, got {self.id!r}")
        if self.orientation not in ORIENTATION_DIRECTIONS_FRD:
            raise ValueError(
                f"orientation must be a MAV_SENSOR_ROTATION of "
                f"{sorted(ORIENTATION_DIRECTIONS_FRD)} (0 forward, 1..7 YAW_45..YAW_315, 24 up, "
                f"25 down), got {self.orientation!r}"
            )
        position = tuple(float(v) for v in self.position_frd_m)
        if len(position) != 3 or not all(math.isfinite(v) for v in position):
            raise ValueError(f"position_frd_m needs 3 finite numbers, got {self.position_frd_m}")
        object.__setattr__(self, "position_frd_m", position)
        for name in ("min_range_m", "max_range_m", "beam_width_deg", "rate_hz"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if not self.min_range_m < self.max_range_m:
            raise ValueError(
                f"min_range_m ({self.min_range_m}) must be < max_range_m ({self.max_range_m})"
            )
        if self.max_range_m > 655.0:
            raise ValueError(f"max_range_m must be <= 655 m (uint16 cm), got {self.max_range_m}")
        if not self.beam_width_deg < 180.0:
            raise ValueError(f"beam_width_deg must be < 180, got {self.beam_width_deg}")
        for name in ("noise_sigma_m", "noise_per_m"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if not 0.0 <= self.dropout_probability < 1.0:
            raise ValueError(
                f"dropout_probability must be in [0, 1), got {self.dropout_probability}"
            )

    @property
    def direction_frd(self) -> np.ndarray:
        """Unit vector of the beam axis, body FRD."""
        return np.array(ORIENTATION_DIRECTIONS_FRD[self.orientation])

    @property
    def fov_rad(self) -> float:
        """Full beam angle, rad (DISTANCE_SENSOR horizontal_fov and vertical_fov)."""
        return math.radians(self.beam_width_deg)

    def noise_sigma_at(self, range_m: np.ndarray | float) -> np.ndarray | float:
        """1-sigma range noise at a range, m."""
        return self.noise_sigma_m + self.noise_per_m * range_m

    def ray_directions_frd(self) -> np.ndarray:
        """Unit vectors of the rays sampling the cone, body FRD, (RAYS_PER_SENSOR, 3).

        Row 0 is the axis; then ring by ring outwards, each ring starting in the plane of the
        axis and body z (or body x for a vertical beam), so that one ray of the outer ring lies in
        each body-axis plane.
        """
        axis = self.direction_frd
        ref = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        u = ref - axis * (ref @ axis)
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        half = math.radians(self.beam_width_deg) / 2.0
        rays = [axis]
        for ring in range(1, RINGS + 1):
            angle = half * ring / RINGS
            for k in range(RAYS_PER_RING):
                phi = 2.0 * math.pi * k / RAYS_PER_RING
                off = math.cos(phi) * u + math.sin(phi) * v
                rays.append(math.cos(angle) * axis + math.sin(angle) * off)
        return np.array(rays)


MODELS: Mapping[str, Mapping[str, float]] = {
    "hc_sr04": {
        "min_range_m": 0.02,
        "max_range_m": 4.5,
        "beam_width_deg": 15.0,
        "rate_hz": 20.0,
        "noise_sigma_m": 0.01,
        "noise_per_m": 0.005,
        "dropout_probability": 0.01,
    },
    "mb1240": {
        "min_range_m": 0.2,
        "max_range_m": 7.0,
        "beam_width_deg": 10.0,
        "rate_hz": 10.0,
        "noise_sigma_m": 0.01,
        "noise_per_m": 0.005,
        "dropout_probability": 0.01,
    },
}
"""Model presets (see the module docstring for their sources)."""

_OVERRIDABLE = frozenset(f.name for f in fields(RangefinderSpec)) - {
    "id",
    "orientation",
    "position_frd_m",
    "model",
}


def rangefinder_from_model(
    model: str, id: int, orientation: int, position_frd_m: Sequence[float], **overrides: float
) -> RangefinderSpec:
    """A RangefinderSpec from a preset of :data:`MODELS` with some numbers overridden.

    Raises:
        ValueError: unknown model or override name, or an invalid value (naming the field).
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {sorted(MODELS)}, got {model!r}")
    unknown = sorted(set(overrides) - _OVERRIDABLE)
    if unknown:
        raise ValueError(f"unknown rangefinder fields {unknown}; known: {sorted(_OVERRIDABLE)}")
    values = {**MODELS[model], **overrides}
    return RangefinderSpec(
        id=id,
        orientation=orientation,
        position_frd_m=tuple(position_frd_m),
        model=model,
        **values,
    )


@dataclass(frozen=True)
class RangeReadings:
    """Readings of the sensors sampled at one tick (one entry per sensor read)."""

    time_usec: int
    """Simulation time of the reading, us."""
    vehicle: np.ndarray
    """Vehicle index of each reading, (K,)."""
    specs: tuple[RangefinderSpec, ...]
    """The sensor of each reading, (K,)."""
    distance_m: np.ndarray
    """Measured range, m; NaN: no echo (out of range or a dropout), (K,)."""
    true_distance_m: np.ndarray
    """Nearest hit in the cone without noise, m; NaN if nothing within max range, (K,)."""


_FLU_FROM_FRD = np.array([1.0, -1.0, -1.0])


class RangefinderArray:
    """Every vehicle's rangefinders, sampled with one ray batch per sensor tick.

    Args:
        client_id: PyBullet client of the scene.
        body_ids: PyBullet body of each vehicle, vehicle order.
        mounts: the rangefinders of each vehicle (empty: none).
        physics_hz: physics rate; every sensor rate must divide it.
        rng: the generator of noise and dropouts (spawned for the rangefinders alone).

    Raises:
        ValueError: a rate that does not divide ``physics_hz`` (naming the vehicle and sensor).
    """

    def __init__(
        self,
        client_id: int,
        body_ids: Sequence[int],
        mounts: Sequence[Sequence[RangefinderSpec]],
        physics_hz: float,
        rng: np.random.Generator,
    ) -> None:
        if len(body_ids) != len(mounts):
            raise ValueError(f"{len(mounts)} mount lists for {len(body_ids)} vehicles")
        self._cid = client_id
        self._rng = rng
        self._physics_hz = float(physics_hz)
        specs: list[RangefinderSpec] = []
        vehicle: list[int] = []
        divisors: list[int] = []
        for i, sensors in enumerate(mounts):
            for spec in sensors:
                name = f"vehicle {i} rangefinder id {spec.id} rate_hz"
                divisors.append(rate_divisor(physics_hz, spec.rate_hz, name))
                specs.append(spec)
                vehicle.append(i)
        self.specs: tuple[RangefinderSpec, ...] = tuple(specs)
        """Every sensor of every vehicle, vehicle by vehicle."""
        self.vehicle = np.array(vehicle, dtype=int)
        """Vehicle index of each sensor."""
        self._divisors = np.array(divisors, dtype=int)
        self._body = np.array(body_ids, dtype=int)[self.vehicle] if specs else np.zeros(0, int)
        self._origin_flu = np.array([s.position_frd_m for s in specs]).reshape(-1, 3)
        self._origin_flu *= _FLU_FROM_FRD
        self._rays_flu = (
            np.array([s.ray_directions_frd() for s in specs]).reshape(-1, RAYS_PER_SENSOR, 3)
            * _FLU_FROM_FRD
        )
        self._max_range = np.array([s.max_range_m for s in specs])
        self._min_range = np.array([s.min_range_m for s in specs])
        self._sigma0 = np.array([s.noise_sigma_m for s in specs])
        self._sigma_k = np.array([s.noise_per_m for s in specs])
        self._dropout = np.array([s.dropout_probability for s in specs])
        self._base_divisor = int(np.gcd.reduce(self._divisors)) if specs else 0
        self.rays_cast = 0
        """Rays cast so far (including re-casts past the vehicles' own bodies)."""

    @property
    def n_sensors(self) -> int:
        """Sensors of all vehicles together."""
        return len(self.specs)

    def due(self, tick: int) -> bool:
        """Whether any sensor reads at physics step ``tick``."""
        return self._base_divisor > 0 and tick % self._base_divisor == 0

    def sample(
        self,
        tick: int,
        time_usec: int,
        position_enu_m: np.ndarray,
        rotation_flu_to_enu: np.ndarray,
    ) -> RangeReadings | None:
        """Read the sensors due at ``tick`` (None if none is), all their rays in one batch.

        Args:
            tick: physics step count (a sensor reads when it is a multiple of its divisor).
            time_usec: simulation time, us (stamped on the readings).
            position_enu_m: centre of mass of each vehicle, (N, 3).
            rotation_flu_to_enu: body FLU -> ENU rotation of each vehicle, (N, 3, 3).
        """
        if not self.due(tick):
            return None
        rows = np.flatnonzero(tick % self._divisors == 0)
        if rows.size == 0:
            return None
        rot = rotation_flu_to_enu[self.vehicle[rows]]
        origins = position_enu_m[self.vehicle[rows]] + np.einsum(
            "kij,kj->ki", rot, self._origin_flu[rows]
        )
        dirs = np.einsum("kij,krj->kri", rot, self._rays_flu[rows])
        n_rays = dirs.shape[1]
        start = np.repeat(origins, n_rays, axis=0)
        dirs = dirs.reshape(-1, 3)
        length = np.repeat(self._max_range[rows], n_rays)
        bodies = np.repeat(self._body[rows], n_rays)
        hit = _cast(self._cid, start, dirs, length, bodies)
        self.rays_cast += hit.cast
        true = np.min(hit.distance_m.reshape(rows.size, n_rays), axis=1)  # inf: nothing hit
        sigma = self._sigma0[rows] + self._sigma_k[rows] * np.where(np.isfinite(true), true, 0.0)
        noise = self._rng.standard_normal(rows.size) * sigma
        dropped = self._rng.random(rows.size) < self._dropout[rows]
        measured = true + noise
        echo = (
            np.isfinite(true)
            & ~dropped
            & (measured >= self._min_range[rows])
            & (measured <= self._max_range[rows])
        )
        return RangeReadings(
            time_usec=time_usec,
            vehicle=self.vehicle[rows],
            specs=tuple(self.specs[k] for k in rows.tolist()),
            distance_m=np.where(echo, measured, np.nan),
            true_distance_m=np.where(np.isfinite(true), true, np.nan),
        )


@dataclass
class _Hits:
    distance_m: np.ndarray
    """Distance from each ray's start to its hit, m; inf where nothing was hit."""
    cast: int
    """Rays cast, re-casts included."""


def _cast(
    cid: int, start: np.ndarray, dirs: np.ndarray, length: np.ndarray, own_body: np.ndarray
) -> _Hits:
    """Cast rays ``start + t dirs``, t in [0, length]; hits on ``own_body`` are looked past."""
    distance = np.full(len(start), np.inf)
    offset = np.zeros(len(start))  # how far along its ray a re-cast starts
    todo = np.arange(len(start))
    cast = 0
    for _ in range(_MAX_RECASTS + 1):
        if todo.size == 0:
            break
        origin = start[todo] + dirs[todo] * offset[todo, None]
        remaining = length[todo] - offset[todo]
        ends = origin + dirs[todo] * remaining[:, None]
        body, fraction = _ray_batch(cid, origin, ends)
        cast += todo.size
        travelled = offset[todo] + fraction * remaining
        hit = body >= 0
        own = hit & (body == own_body[todo])
        other = hit & ~own
        distance[todo[other]] = travelled[other]
        offset[todo[own]] = travelled[own] + _SELF_HIT_STEP_M
        todo = todo[own & (offset[todo] < length[todo])]
    return _Hits(distance, cast)


def _ray_batch(cid: int, origin: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Body id (-1: no hit) and hit fraction of each ray, in batches of PyBullet's limit."""
    bodies: list[int] = []
    fractions: list[float] = []
    for lo in range(0, len(origin), MAX_RAYS_PER_BATCH):
        hi = lo + MAX_RAYS_PER_BATCH
        # PyBullet reads the (K, 3) arrays row by row: no list conversion needed. Rays are
        # independent, so Bullet's worker threads (numThreads=0: as many as it has) cast them in
        # parallel with the same results; on 2 cores that halves the time of 1190 rays.
        results = p.rayTestBatch(
            origin[lo:hi], ends[lo:hi], numThreads=RAY_THREADS, physicsClientId=cid
        )
        body, _, fraction, _, _ = zip(*results, strict=True)
        bodies.extend(body)
        fractions.extend(fraction)
    return np.array(bodies, dtype=int), np.array(fractions, dtype=float)
