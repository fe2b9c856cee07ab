"""What a companion program started by ``swarmsitl run`` is told, through its environment.

A scenario names one companion program per role; the runner starts one process per vehicle and
describes that vehicle's place in the run with ``SWARMSITL_*`` variables. On a Raspberry Pi the
same program gets the same variables from its service file (``docs/scenarios.md``), so nothing in
it depends on the simulator. :class:`ScenarioEnv` reads and writes them; it has no I/O beyond
``os.environ``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

PREFIX = "SWARMSITL_"


class ScenarioEnvError(ValueError):
    """A ``SWARMSITL_*`` variable is missing or malformed (the message names it)."""


@dataclass(frozen=True)
class ScenarioEnv:
    """One vehicle's companion: how to reach its autopilot and where it stands in the run."""

    mavlink_url: str
    """MAVSDK connection URL of the vehicle's onboard link, e.g. ``udpin://0.0.0.0:14540``
    (``SWARMSITL_MAVLINK_URL``); pymavlink: :attr:`pymavlink_url`."""
    grpc_port: int
    """Port for this process's ``mavsdk_server`` (unique per vehicle in a run)."""
    vehicle: int
    """MAVLink system id of the vehicle, 1-based (vehicle index + 1)."""
    vehicles: int
    """Number of vehicles in the run."""
    role: str
    """The vehicle's role in the scenario, e.g. ``coverage``."""
    role_index: int
    """0-based index of the vehicle among the vehicles of its role."""
    role_count: int
    """Number of vehicles with this role."""
    seed: int
    """The run's seed (seed your own generator from it for repeatable runs)."""
    out_dir: Path
    """Directory for this companion's outputs; ``result.json`` there joins the report."""
    world: Path | None = None
    """The world YAML of the run (``worlds.build(worlds.load_world(path))`` rebuilds it)."""
    origin: tuple[float, float, float] | None = None
    """Geodetic origin of the world frame (ENU 0, 0, 0): latitude, longitude (deg), AMSL (m)."""
    video_uri: str | None = None
    """Where the vehicle's camera streams (``cv2.VideoCapture(uri)``); None: no camera."""
    duration_s: float | None = None
    """Simulated seconds the run lasts (the companion should have landed by then)."""
    params: Mapping[str, object] | None = None
    """The role's ``args`` from the scenario, as JSON (``SWARMSITL_PARAMS``)."""
    fleet: tuple[dict, ...] | None = None
    """Every vehicle of the run in vehicle order (``SWARMSITL_FLEET``, a JSON list): ``vehicle``
    (1-based id), ``role``, ``role_index``, ``airframe``, ``battery_capacity_mah`` (its pack's,
    mAh), ``traits`` (the fleet file's free-form capabilities, name -> number), ``priority``
    (integer, :attr:`priority`) and ``diameter_m`` (the airframe's rotor tip to rotor tip, m:
    the sphere the run's collision count takes it for)."""

    @property
    def fleet_entry(self) -> dict | None:
        """This vehicle's entry of :attr:`fleet` (None: no fleet given)."""
        if self.fleet is None or not 1 <= self.vehicle <= len(self.fleet):
            return None
        return self.fleet[self.vehicle - 1]

    @property
    def priority(self) -> int:
        """The vehicle's priority: its fleet entry's ``priority``, else its vehicle number.

        The scenario's ``fleet[].priority`` (seed 001's ground-station rank); the same number the
        swarm engine gives ``SwarmVehicle.priority``.
        """
        entry = self.fleet_entry
        value = None if entry is None else entry.get("priority")
        return self.vehicle if value is None else int(value)

    @property
    def pymavlink_url(self) -> str:
        """The same link in pymavlink's notation (``udpin:0.0.0.0:14540``)."""
        scheme, _, rest = self.mavlink_url.partition("://")
        return f"{scheme}:{rest}"

    def to_env(self) -> dict[str, str]:
        """The variables describing this companion (strings, for ``subprocess.Popen(env=...)``)."""
        env = {
            "MAVLINK_URL": self.mavlink_url,
            "GRPC_PORT": str(self.grpc_port),
            "VEHICLE": str(self.vehicle),
            "VEHICLES": str(self.vehicles),
            "ROLE": self.role,
            "ROLE_INDEX": str(self.role_index),
            "ROLE_COUNT": str(self.role_count),
            "SEED": str(self.seed),
            "OUT": str(self.out_dir),
        }
        if self.world is not None:
            env["WORLD"] = str(self.world)
        if self.origin is not None:
            env["ORIGIN"] = ",".join(repr(float(v)) for v in self.origin)
        if self.video_uri is not None:
            env["VIDEO_URI"] = self.video_uri
        if self.duration_s is not None:
            env["DURATION_S"] = repr(float(self.duration_s))
        if self.params is not None:
            env["PARAMS"] = json.dumps(dict(self.params))
        if self.fleet is not None:
            env["FLEET"] = json.dumps([dict(entry) for entry in self.fleet])
        return {PREFIX + k: v for k, v in env.items()}

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> ScenarioEnv:
        """Read the variables ``swarmsitl run`` sets (``ScenarioEnvError`` naming a bad one)."""
        env = os.environ if environ is None else environ

        def get(name: str, default: str | None = None) -> str:
            value = env.get(PREFIX + name, default)
            if value is None:
                raise ScenarioEnvError(
                    f"{PREFIX}{name} is not set: start this program with `swarmsitl run` "
                    "or set the SWARMSITL_* variables (docs/scenarios.md)"
                )
            return value

        def number(name: str, kind: type, default: str | None = None) -> int | float:
            text = get(name, default)
            try:
                return kind(text)
            except ValueError as exc:
                raise ScenarioEnvError(f"{PREFIX}{name}={text!r}: not a number") from exc

        origin = None
        if PREFIX + "ORIGIN" in env:
            parts = get("ORIGIN").split(",")
            try:
                lat, lon, alt = (float(p) for p in parts)
            except ValueError as exc:
                raise ScenarioEnvError(
                    f"{PREFIX}ORIGIN={get('ORIGIN')!r}: expected LAT,LON,ALT_AMSL"
                ) from exc
            origin = (lat, lon, alt)

        def parsed(name: str) -> object:
            try:
                return json.loads(get(name))
            except json.JSONDecodeError as exc:
                raise ScenarioEnvError(f"{PREFIX}{name} is not JSON: {exc}") from exc

        params = None
        if PREFIX + "PARAMS" in env:
            params = parsed("PARAMS")
            if not isinstance(params, dict):
                raise ScenarioEnvError(f"{PREFIX}PARAMS must be a JSON object")
        fleet = None
        if PREFIX + "FLEET" in env:
            entries = parsed("FLEET")
            if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
                raise ScenarioEnvError(f"{PREFIX}FLEET must be a JSON list of objects")
            fleet = tuple(entries)
        vehicle = int(number("VEHICLE", int))
        return cls(
            mavlink_url=get("MAVLINK_URL"),
            grpc_port=int(number("GRPC_PORT", int, str(50050 + vehicle))),
            vehicle=vehicle,
            vehicles=int(number("VEHICLES", int, "1")),
            role=get("ROLE", "default"),
            role_index=int(number("ROLE_INDEX", int, "0")),
            role_count=int(number("ROLE_COUNT", int, "1")),
            seed=int(number("SEED", int, "0")),
            out_dir=Path(get("OUT", ".")),
            world=Path(get("WORLD")) if PREFIX + "WORLD" in env else None,
            origin=origin,
            video_uri=env.get(PREFIX + "VIDEO_URI"),
            duration_s=(
                float(number("DURATION_S", float)) if PREFIX + "DURATION_S" in env else None
            ),
            params=params,
            fleet=fleet,
        )

    def write_result(self, metrics: Mapping[str, tuple[float | int | str, str]]) -> Path:
        """Write ``result.json`` (``{name: {"value": v, "unit": u}}``) for the run's report."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        path = self.out_dir / "result.json"
        body = {name: {"value": value, "unit": unit} for name, (value, unit) in metrics.items()}
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(body, indent=2) + "\n")
        tmp.replace(path)
        return path
