"""GNSS receivers of N vehicles: delayed fixes whose error, accuracy and satellites agree.

One measurement epoch per ``1 / gps_hz``; every quantity is an (N, ...) array. Per receiver:

- satellites visible ``n = clip(round(mean + sigma s), 0, max)`` with ``s`` a unit first-order
  Gauss-Markov process whose correlation time is minutes (satellites rise and set slowly);
- dilution of precision from the count: ``HDOP = HDOP_ref sqrt((n_ref - 2) / max(n - 2, 1))``
  (DOP falls roughly as one over the square root of the redundant ranges), ``VDOP = r HDOP``;
- accuracy from the user equivalent range error (UERE): the horizontal error variance is
  ``HDOP^2 UERE^2`` (Kaplan and Hegarty, *Understanding GPS*, 2nd ed., sec. 7.3), split evenly
  over north and east, so ``eph = HDOP UERE / sqrt(2)`` per axis and ``epv = VDOP UERE``. These
  are what HIL_GPS reports, in cm, as PX4's simulator reads them (1-sigma accuracy, m x 100);
- the position error has exactly that standard deviation: a wandering part (a unit Gauss-Markov
  process with PX4's 60 s ``gps_corellation_time_`` scaled by ``sqrt(eph^2 - white^2)``) plus
  white receiver noise; velocity error is white noise. The wandering unit process is a mix:
  ``common_error_fraction`` of its variance is one process every receiver of the world shares
  (:class:`SharedGnssError`: atmosphere, satellite clocks and orbits), the rest the receiver's
  own, so that neighbouring vehicles' fixes err together as real receivers' do;
- fix type from the count: 0-2 satellites no fix, 3 a 2D fix, 4 or more a 3D fix;
- outages (:class:`GpsOutages`): scripted windows and/or a seeded two-state random process;
  during an outage the receiver reports no fix (``fix_type`` 1), 0 satellites and unknown
  accuracy;
- delay: a fix is measured ``delay_ms`` (rounded to a physics step) before it is sent (PX4
  gazebo-classic GPS plugin: ``gps_delay_ = 0.12`` s). :meth:`Gps.poll`, called every physics
  step, measures on the steps ``delay`` before each send and returns the fix on send steps.

Every draw comes from the generator passed in, in a fixed order per epoch (satellites, outage
process if enabled, wandering error, white noise); the draws do not depend on the outage state.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from sitl import frames
from sitl.clock import rate_divisor
from sitl.sensors.noise import GaussMarkov

FIX_NONE = 1
"""GPS_FIX_TYPE_NO_FIX: receiver present, no position."""
FIX_2D = 2
"""GPS_FIX_TYPE_2D_FIX."""
FIX_3D = 3
"""GPS_FIX_TYPE_3D_FIX."""
MIN_SATELLITES_2D = 3
"""Satellites needed for a 2D fix (latitude, longitude, clock)."""
MIN_SATELLITES_3D = 4
"""Satellites needed for a 3D fix (position and clock)."""


@dataclass(frozen=True)
class GpsParams:
    """Error model and reported quality of one GNSS receiver (units in the names)."""

    delay_ms: float
    """Age of a fix when it is sent (measurement to HIL_GPS), ms."""
    uere_m: float
    """User equivalent range error, 1 sigma, m."""
    hdop_reference: float
    """Horizontal dilution of precision with ``satellites_reference`` satellites, 1."""
    satellites_reference: int
    """Satellite count at which HDOP is ``hdop_reference``, 1."""
    vdop_per_hdop: float
    """Ratio VDOP / HDOP, 1."""
    satellites_mean: float
    """Mean number of satellites visible, 1."""
    satellites_sigma: float
    """Standard deviation of the satellite count, 1."""
    satellites_max: int
    """Largest count reported, 1."""
    satellites_correlation_time_s: float
    """Correlation time of the satellite count, s."""
    bias_correlation_time_s: float
    """Correlation time of the wandering position error, s."""
    horizontal_noise_sigma_m: float
    """White position noise std per horizontal axis, m (part of eph)."""
    vertical_noise_sigma_m: float
    """White position noise std, vertical, m (part of epv)."""
    horizontal_velocity_noise_sigma_m_s: float
    """White velocity noise std per horizontal axis, m/s."""
    vertical_velocity_noise_sigma_m_s: float
    """White velocity noise std, vertical, m/s."""
    common_error_fraction: float = 0.9
    """Share of the wandering error's variance common to every receiver of the world, 0..1.

    Most of a standalone receiver's ranging error is the same for receivers a few kilometres
    apart, which see the same satellites through the same sky: satellite clock and ephemeris,
    ionospheric and tropospheric delays dominate the single-frequency UERE budget, multipath and
    receiver noise are local (Kaplan and Hegarty, *Understanding GPS*, 2nd ed., table 7.4; the
    reason differential GNSS works). 0.9 (assumed from that budget): two receivers of the swarm
    disagree by sqrt(2 x 0.1) ~ 0.45 of one receiver's error, not by sqrt(2) of it.
    """

    def __post_init__(self) -> None:
        if self.delay_ms < 0.0:
            raise ValueError(f"delay_ms must be >= 0, got {self.delay_ms}")
        for name in ("uere_m", "hdop_reference", "vdop_per_hdop"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if self.satellites_reference <= 2:
            raise ValueError(f"satellites_reference must be > 2: {self.satellites_reference}")
        if not (self.satellites_sigma >= 0.0 and self.satellites_max >= MIN_SATELLITES_3D):
            raise ValueError("satellites_sigma must be >= 0 and satellites_max >= 4")
        for name in ("satellites_correlation_time_s", "bias_correlation_time_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0.0 <= self.common_error_fraction <= 1.0:
            raise ValueError(f"common_error_fraction must be in 0..1: {self.common_error_fraction}")

    def dop(self, satellites: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(HDOP, VDOP) for satellite counts (N,)."""
        redundant = np.maximum(np.asarray(satellites, dtype=float) - 2.0, 1.0)
        hdop = self.hdop_reference * np.sqrt((self.satellites_reference - 2.0) / redundant)
        return hdop, self.vdop_per_hdop * hdop

    def accuracy_m(self, satellites: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(eph, epv): 1-sigma error per horizontal axis and vertical, m (>= the white noise)."""
        hdop, vdop = self.dop(satellites)
        eph = np.maximum(hdop * self.uere_m / math.sqrt(2.0), self.horizontal_noise_sigma_m)
        epv = np.maximum(vdop * self.uere_m, self.vertical_noise_sigma_m)
        return eph, epv


@dataclass(frozen=True)
class GpsOutageWindow:
    """A scripted interval without GNSS fix (e.g. a tunnel, jamming), simulation time."""

    start_s: float
    """Start of the outage (measurement time), s."""
    end_s: float
    """End of the outage (exclusive), s."""
    vehicle: int | None = None
    """Index of the vehicle affected; None: every vehicle."""

    def __post_init__(self) -> None:
        if not self.end_s > self.start_s:
            raise ValueError(f"GPS outage must end after it starts: {self}")


@dataclass(frozen=True)
class GpsOutages:
    """When receivers lose their fix. Default: never.

    Scripted ``windows`` apply to fixes measured inside them (so messages sent ``delay_ms``
    later report no fix). The random process, on when ``mean_interval_s`` is set, is a two-state
    Markov chain per vehicle evaluated at each epoch: an outage starts with probability
    ``1 - exp(-dt / mean_interval_s)`` and ends with ``1 - exp(-dt / mean_duration_s)``, so
    times between outages and their durations are exponential with these means.
    """

    windows: tuple[GpsOutageWindow, ...] = ()
    """Scripted outages; entries may also be given as (start_s, end_s[, vehicle]) sequences."""
    mean_interval_s: float | None = None
    """Mean time with a fix between random outages, s; None: no random outages."""
    mean_duration_s: float = 10.0
    """Mean duration of a random outage, s."""

    def __post_init__(self) -> None:
        windows = tuple(
            w if isinstance(w, GpsOutageWindow) else GpsOutageWindow(*w) for w in self.windows
        )
        object.__setattr__(self, "windows", windows)
        if self.mean_interval_s is not None and not self.mean_interval_s > 0.0:
            raise ValueError(f"mean_interval_s must be positive or None: {self.mean_interval_s}")
        if not self.mean_duration_s > 0.0:
            raise ValueError(f"mean_duration_s must be positive: {self.mean_duration_s}")

    def scripted(self, time_s: float, vehicle_ids: np.ndarray) -> np.ndarray:
        """Mask of the vehicles (world indices ``vehicle_ids``) inside a window at ``time_s``."""
        out = np.zeros(len(vehicle_ids), dtype=bool)
        for w in self.windows:
            if w.start_s <= time_s < w.end_s:
                out |= True if w.vehicle is None else vehicle_ids == w.vehicle
        return out


@dataclass(frozen=True)
class GpsSample:
    """One GNSS epoch of N vehicles (what one HIL_GPS per vehicle carries)."""

    time_s: float
    """Measurement time (simulation clock), s."""
    lat_deg: np.ndarray
    """Latitude, degrees, (N,); 0 without a fix."""
    lon_deg: np.ndarray
    """Longitude, degrees, (N,); 0 without a fix."""
    alt_amsl_m: np.ndarray
    """Altitude above mean sea level, m, (N,); 0 without a fix."""
    velocity_ned_m_s: np.ndarray
    """Velocity north, east, down, m/s, (N, 3); 0 without a fix."""
    fix_type: np.ndarray
    """GPS_FIX_TYPE per vehicle, (N,) int."""
    satellites: np.ndarray
    """Satellites visible (used), (N,) int."""
    eph_m: np.ndarray
    """1-sigma horizontal accuracy per axis, m, (N,); NaN without a fix."""
    epv_m: np.ndarray
    """1-sigma vertical accuracy, m, (N,); NaN without a fix."""

    @classmethod
    def no_fix(cls, n_vehicles: int, time_s: float) -> GpsSample:
        """What a receiver without a solution reports (e.g. before its first fix)."""
        zeros = np.zeros(n_vehicles)
        return cls(
            time_s=time_s,
            lat_deg=zeros,
            lon_deg=zeros,
            alt_amsl_m=zeros,
            velocity_ned_m_s=np.zeros((n_vehicles, 3)),
            fix_type=np.full(n_vehicles, FIX_NONE),
            satellites=np.zeros(n_vehicles, dtype=int),
            eph_m=np.full(n_vehicles, np.nan),
            epv_m=np.full(n_vehicles, np.nan),
        )


class SharedGnssError:
    """The part of the GNSS error every receiver of a world shares.

    One unit Gauss-Markov 3-vector (ENU) per correlation time, advanced once per measurement
    epoch by whichever receiver (airframe group) asks first, so that all read the same value.
    """

    def __init__(self, rng: np.random.Generator) -> None:
        self._rng = rng
        self._processes: dict[float, tuple[GaussMarkov, list[float]]] = {}

    def at(self, time_s: float, dt_s: float, correlation_time_s: float) -> np.ndarray:
        """The (3,) unit error at ``time_s``; ``dt_s`` since the previous epoch."""
        entry = self._processes.get(correlation_time_s)
        if entry is None:
            entry = (GaussMarkov(np.ones(3), correlation_time_s, self._rng), [time_s])
            self._processes[correlation_time_s] = entry
            return entry[0].value
        process, last = entry
        if time_s > last[0]:
            process.advance(dt_s)
            last[0] = time_s
        return process.value


class Gps:
    """GNSS receivers of N vehicles, antenna at the centre of mass.

    Call :meth:`poll` after every physics step: it measures the true state on the steps that lie
    the receiver's delay before a send step, queues the fix, and on send steps (every
    ``physics_hz / gps_hz``) returns the queued fix that is due, or a no-fix sample before the
    first one.

    Args:
        rows: which rows of the world's (N_world, 3) arrays are these receivers' vehicles (a
            slice or an index array; all rows by default). Scripted outages name world indices.
        shared_error: the world's common error (:class:`SharedGnssError`); by default one of
            these receivers' own (a world hands every airframe group the same one).
    """

    def __init__(
        self,
        params: GpsParams,
        origin: frames.GeodeticOrigin,
        n_vehicles: int,
        rng: np.random.Generator,
        outages: GpsOutages | None = None,
        *,
        physics_hz: float,
        gps_hz: float,
        rows: slice | np.ndarray | None = None,
        shared_error: SharedGnssError | None = None,
    ) -> None:
        self.params = params
        self.shared_error = shared_error if shared_error is not None else SharedGnssError(rng)
        """The error this receiver shares with the world's others (its own when alone)."""
        self.outages = outages or GpsOutages()
        self._origin = origin
        self._n = n_vehicles
        self._rng = rng
        self._rows = slice(None) if rows is None else rows
        self.vehicle_ids = (
            np.arange(n_vehicles)
            if rows is None
            else np.arange(rows.start or 0, rows.stop, rows.step or 1)
            if isinstance(rows, slice)
            else np.asarray(rows)
        )
        """World index of each receiver's vehicle, (N,)."""
        if len(self.vehicle_ids) != n_vehicles:
            raise ValueError(f"rows select {len(self.vehicle_ids)} vehicles, not {n_vehicles}")
        self._dt_s = 1.0 / physics_hz
        self._send_div = rate_divisor(physics_hz, gps_hz, "gps_hz")
        self.delay_ticks = round(params.delay_ms * 1e-3 * physics_hz)
        """The delay in physics steps."""
        self._last_measure_tick: int | None = None
        self.satellite_process = GaussMarkov(
            np.ones(n_vehicles), params.satellites_correlation_time_s, rng
        )
        self.bias_unit_enu = GaussMarkov(
            np.ones((n_vehicles, 3)), params.bias_correlation_time_s, rng
        )
        """Wandering position error before scaling to the current accuracy, ENU, unit std."""
        self.in_random_outage = np.zeros(n_vehicles, dtype=bool)
        self._white_pos = np.array(
            [params.horizontal_noise_sigma_m] * 2 + [params.vertical_noise_sigma_m]
        )
        self._vel_sigma = np.array(
            [params.horizontal_velocity_noise_sigma_m_s] * 2
            + [params.vertical_velocity_noise_sigma_m_s]
        )
        self._queue: deque[GpsSample] = deque()

    @property
    def delay_s(self) -> float:
        """Age of a fix when sent (rounded to a physics step), s."""
        return self.delay_ticks * self._dt_s

    def poll(
        self, tick: int, position_enu_m: np.ndarray, velocity_enu_m_s: np.ndarray
    ) -> GpsSample | None:
        """Advance to physics step ``tick`` with the world's true state (N_world, 3) ENU.

        Returns the fix to send if ``tick`` is a send step, else None.
        """
        if (tick + self.delay_ticks) % self._send_div == 0 and tick != self._last_measure_tick:
            last = self._last_measure_tick
            self._last_measure_tick = tick
            steps = tick - last if last is not None else self._send_div
            rows = self._rows
            self.measure(
                tick * self._dt_s, position_enu_m[rows], velocity_enu_m_s[rows], steps * self._dt_s
            )
        if tick % self._send_div:
            return None
        return self.report(tick * self._dt_s, self.delay_s)

    def satellites(self) -> np.ndarray:
        """Current satellite counts (N,) from the satellite process (no outage applied)."""
        p = self.params
        count = np.rint(p.satellites_mean + p.satellites_sigma * self.satellite_process.value)
        return np.clip(count, 0, p.satellites_max).astype(int)

    def _advance_outages(self, dt_s: float) -> None:
        mean_interval = self.outages.mean_interval_s
        if mean_interval is None:
            return
        u = self._rng.random(self._n)
        start = -math.expm1(-dt_s / mean_interval)
        stop = -math.expm1(-dt_s / self.outages.mean_duration_s)
        state = self.in_random_outage
        self.in_random_outage = np.where(state, u >= stop, u < start)

    def measure(
        self,
        time_s: float,
        position_enu_m: np.ndarray,
        velocity_enu_m_s: np.ndarray,
        dt_s: float,
    ) -> GpsSample:
        """Fix of true positions/velocities (N, 3) ENU at ``time_s``; queue it and return it.

        ``dt_s`` is the time since the previous measurement.
        """
        p = self.params
        self.satellite_process.advance(dt_s)
        self._advance_outages(dt_s)
        own = self.bias_unit_enu.advance(dt_s)
        common = self.shared_error.at(time_s, dt_s, p.bias_correlation_time_s)
        c = p.common_error_fraction
        unit_bias = math.sqrt(c) * common + math.sqrt(1.0 - c) * own
        z = self._rng.standard_normal((2, *position_enu_m.shape))

        satellites = self.satellites()
        eph, epv = p.accuracy_m(satellites)
        total = np.column_stack((eph, eph, epv))
        wander = np.sqrt(np.maximum(total**2 - self._white_pos**2, 0.0))
        pos = position_enu_m + wander * unit_bias + self._white_pos * z[0]
        vel = velocity_enu_m_s + self._vel_sigma * z[1]
        lat, lon, alt = frames.enu_to_geodetic(pos, self._origin)

        fix = np.where(
            satellites >= MIN_SATELLITES_3D,
            FIX_3D,
            np.where(satellites >= MIN_SATELLITES_2D, FIX_2D, FIX_NONE),
        )
        outage = self.in_random_outage | self.outages.scripted(time_s, self.vehicle_ids)
        lost = outage | (fix == FIX_NONE)
        if lost.any():
            keep = ~lost
            lat, lon, alt = lat * keep, lon * keep, alt * keep
            vel = vel * keep[:, None]
            fix = np.where(lost, FIX_NONE, fix)
            satellites = np.where(outage, 0, satellites)
            eph = np.where(lost, np.nan, eph)
            epv = np.where(lost, np.nan, epv)
        sample = GpsSample(
            time_s=time_s,
            lat_deg=lat,
            lon_deg=lon,
            alt_amsl_m=alt,
            velocity_ned_m_s=frames.enu_to_ned(vel),
            fix_type=fix,
            satellites=satellites,
            eph_m=eph,
            epv_m=epv,
        )
        self._queue.append(sample)
        return sample

    def report(self, time_s: float, delay_s: float) -> GpsSample:
        """The oldest queued fix at least ``delay_s`` old at ``time_s``, else a no-fix sample."""
        if self._queue and self._queue[0].time_s <= time_s - delay_s + 1e-9:
            return self._queue.popleft()
        return GpsSample.no_fix(self._n, time_s)
