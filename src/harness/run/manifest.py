"""The run manifest: what a run directory holds a run of (``RUN/manifest.json``).

``swarmsitl run`` writes it when the run starts (``complete`` false, ``sim_time_s`` 0) and again
when it ends, so a directory left by a Ctrl-C'd or crashed run still says which seed, fleet and
world it ran. ``swarmsitl replay`` reads it to rebuild the scene. Writes are atomic (a temporary
file in the run directory replaced over the old one): a reader never sees half a manifest.

Units: SI, named in the fields; positions in the world's ENU frame (m), the origin geodetic
(degrees, m above mean sea level).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import importlib.metadata
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from harness.sim.simulation import Simulation

MANIFEST_FILE = "manifest.json"
"""Name of the manifest in a run directory."""
FORMAT_VERSION = 1
"""Version of the manifest's JSON layout; readers refuse newer ones."""


class ManifestError(ValueError):
    """A manifest that is missing, not JSON, of a newer format or with a wrong field."""


def swarmsitl_version() -> str:
    """The installed swarmsitl distribution's version ("unknown" when run from a bare tree)."""
    try:
        return importlib.metadata.version("swarmsitl")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


def utc_now() -> str:
    """The current UTC time, ISO 8601 to the second (e.g. ``2026-12-01T16:24:26+00:00``)."""
    return dt.datetime.now(dt.UTC).isoformat(timespec="seconds")


@dataclass(frozen=True)
class RunManifest:
    """The facts of one run a reader needs without the scenario file: fleet, world, clock."""

    seed: int
    """Seed of every random draw of the run."""
    n_vehicles: int
    """Number of vehicles (vehicle i of the other fields is truth.csv's ``vehicle`` i)."""
    airframes: tuple[str, ...]
    """Airframe of each vehicle: a name of ``sitl/vehicles`` or the path of an airframe folder."""
    roles: tuple[str, ...]
    """Role of each vehicle in the scenario, "" for none."""
    world: str | None
    """The world file's path relative to the run directory (``world.yaml``); None: no world."""
    spawn_enu_m: tuple[tuple[float, float, float], ...]
    """Spawn point of each vehicle's centre of mass, world ENU, m."""
    origin: tuple[float, float, float]
    """Geodetic position of world ENU (0, 0, 0): latitude deg, longitude deg, altitude AMSL m."""
    physics_hz: float
    """Physics rate, Hz."""
    record_hz: float
    """Rate of truth.csv's samples, Hz of simulation time (0: none recorded)."""
    duration_s: float | None
    """Simulated duration asked for, s; None: until stopped."""
    sim_time_s: float = 0.0
    """Simulation time the run reached, s (0 in the manifest written at the start)."""
    complete: bool = False
    """True once the run ended as asked (not stopped early, not crashed)."""
    started_utc: str = field(default_factory=utc_now)
    """When the run started, ISO 8601 with its UTC offset."""
    swarmsitl_version: str = field(default_factory=swarmsitl_version)
    """Version of swarmsitl that ran it."""
    format_version: int = FORMAT_VERSION
    """Version of the manifest layout."""

    def __post_init__(self) -> None:
        n = self.n_vehicles
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise ValueError(f"n_vehicles must be an integer >= 1, got {n!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int):
            raise ValueError(f"seed must be an integer, got {self.seed!r}")
        for name in ("airframes", "roles"):
            value = getattr(self, name)
            if isinstance(value, str) or not all(isinstance(v, str) for v in value):
                raise ValueError(f"{name} must be a list of strings, got {value!r}")
            object.__setattr__(self, name, tuple(value))
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name}: need one per vehicle ({n}), got {len(value)}")
        try:
            spawn = tuple(tuple(float(c) for c in point) for point in self.spawn_enu_m)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"spawn_enu_m must be [east, north, up] triples: {exc}") from exc
        if len(spawn) != n or any(len(s) != 3 or not _finite(*s) for s in spawn):
            raise ValueError(
                f"spawn_enu_m: need one finite [east, north, up] per vehicle ({n}), got {spawn}"
            )
        object.__setattr__(self, "spawn_enu_m", spawn)
        try:
            origin = tuple(float(c) for c in self.origin)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"origin must be [lat_deg, lon_deg, alt_amsl_m]: {exc}") from exc
        if len(origin) != 3 or not _finite(*origin):
            raise ValueError(f"origin must be 3 finite numbers, got {self.origin!r}")
        if not (-90.0 <= origin[0] <= 90.0 and -180.0 <= origin[1] <= 180.0):
            raise ValueError(f"origin: latitude/longitude out of range: {origin}")
        object.__setattr__(self, "origin", origin)
        if self.world is not None:
            if not isinstance(self.world, str) or not self.world:
                raise ValueError(f"world must be a file name or None, got {self.world!r}")
            path = PurePath(self.world)
            if path.is_absolute() or ".." in path.parts:
                raise ValueError(f"world must be a path inside the run directory: {self.world!r}")
        for name, low in (("physics_hz", 0.0), ("record_hz", 0.0), ("sim_time_s", 0.0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) or not _finite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
            ok = value > low if name == "physics_hz" else value >= low
            if not ok:
                raise ValueError(f"{name} must be {'>' if name == 'physics_hz' else '>='} 0")
        d = self.duration_s
        if d is not None and (
            isinstance(d, bool) or not isinstance(d, int | float) or not (_finite(d) and d > 0)
        ):
            raise ValueError(f"duration_s must be a positive number or None, got {d!r}")
        if not isinstance(self.complete, bool):
            raise ValueError(f"complete must be true or false, got {self.complete!r}")
        try:
            dt.datetime.fromisoformat(self.started_utc)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"started_utc must be an ISO 8601 time: {self.started_utc!r}") from exc
        if not isinstance(self.swarmsitl_version, str):
            raise ValueError(f"swarmsitl_version must be a string: {self.swarmsitl_version!r}")
        v = self.format_version
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise ValueError(f"format_version must be an integer >= 1, got {v!r}")

    def finished(self, sim_time_s: float, complete: bool) -> RunManifest:
        """This manifest with the time reached and whether the run completed (the end's)."""
        return dataclasses.replace(self, sim_time_s=float(sim_time_s), complete=complete)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict, format version first."""
        data = dataclasses.asdict(self)
        data["spawn_enu_m"] = [list(s) for s in self.spawn_enu_m]
        order = ["format_version", "swarmsitl_version"]
        return {k: _listed(data[k]) for k in order + [k for k in data if k not in order]}

    @classmethod
    def from_simulation(
        cls,
        sim: Simulation,
        duration_s: float | None,
        roles: tuple[str, ...] = (),
        world: str | None = None,
    ) -> RunManifest:
        """The start manifest of ``sim``; call it before the first step (spawn = the poses now).

        Args:
            sim: The run's simulation, not yet stepped.
            duration_s: Simulated seconds asked for; None: until stopped.
            roles: Each vehicle's role ("" for none); empty: no roles.
            world: The world file's name in the run directory, or None.
        """
        if sim.time_s > 0.0:
            raise ValueError(
                f"from_simulation needs the spawn poses: call it before the first step "
                f"(simulation time is {sim.time_s:g} s)"
            )
        n = sim.config.n_vehicles
        origin = sim.world.origin
        return cls(
            seed=sim.config.seed,
            n_vehicles=n,
            airframes=sim.world.config.airframes,
            roles=tuple(roles) if roles else ("",) * n,
            world=world,
            spawn_enu_m=tuple(map(tuple, sim.world.truth.position_enu_m.tolist())),
            origin=(origin.lat_deg, origin.lon_deg, origin.alt_amsl_m),
            physics_hz=sim.config.physics_hz,
            record_hz=sim.config.record_hz,
            duration_s=duration_s,
        )


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def _listed(value: Any) -> Any:
    """Tuples as lists (nested), for JSON."""
    if isinstance(value, tuple | list):
        return [_listed(v) for v in value]
    return value


def write_manifest(run_dir: Path, manifest: RunManifest) -> Path:
    """Write ``run_dir/manifest.json`` atomically (temporary file, then replace); its path."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    target = run_dir / MANIFEST_FILE
    text = json.dumps(manifest.to_json(), indent=2) + "\n"
    fd, tmp = tempfile.mkstemp(dir=run_dir, prefix=".manifest-", suffix=".json.tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def read_manifest(run_dir: Path) -> RunManifest:
    """Read ``run_dir/manifest.json``.

    Raises:
        ManifestError: the file is missing or unreadable, not JSON, written by a newer swarmsitl
            (a newer ``format_version``), or has a missing, unknown or wrong field (named).
    """
    path = Path(run_dir) / MANIFEST_FILE
    try:
        text = path.read_text()
    except FileNotFoundError as exc:
        raise ManifestError(f"{path}: no run manifest (not a swarmsitl run directory?)") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise ManifestError(f"{path}: cannot read the run manifest: {exc}") from exc
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ManifestError(
            f"{path}:{exc.lineno}:{exc.colno}: corrupt run manifest, not JSON ({exc.msg})"
        ) from exc
    if not isinstance(data, dict):
        raise ManifestError(f"{path}: corrupt run manifest: a JSON object expected")
    version = data.get("format_version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise ManifestError(f"{path}: format_version missing or not an integer: {version!r}")
    if version > FORMAT_VERSION:
        raise ManifestError(
            f"{path}: manifest format {version} is newer than this swarmsitl reads "
            f"({FORMAT_VERSION}); it was written by swarmsitl "
            f"{data.get('swarmsitl_version', '?')}: upgrade swarmsitl to read it"
        )
    names = {f.name for f in dataclasses.fields(RunManifest)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ManifestError(f"{path}: unknown field(s) {', '.join(unknown)}")
    missing = sorted(names - set(data))
    if missing:
        raise ManifestError(f"{path}: missing field(s) {', '.join(missing)}")
    try:
        return RunManifest(**data)
    except (TypeError, ValueError) as exc:
        raise ManifestError(f"{path}: {exc}") from exc
