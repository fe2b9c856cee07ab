"""The scenario file: world + fleet + one companion program per role + links + duration + seed.

``load_scenario(path)`` validates a scenario YAML against a pydantic schema (unknown keys, wrong
types and missing fields are errors naming file, line and field, as for world files), then checks
what the schema alone cannot: that every group's role has a program, that the world file exists
and is valid, that airframes, launch areas, link presets and autopilot parameters are known, and
that each role's ``args`` are what its program declares it takes (``harness.run.companion_args``).
A misspelt name is reported with the close known ones ("did you mean ...?",
``harness.options.suggest``).
Nothing starts before all of that passed. ``docs/scenarios.md`` describes every key.
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
import types
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, model_validator

import worlds
from autopilot_emu.params import ParamStore
from companion.role_params import RUN_CHECK, params_from_mapping
from harness.net.plan import VEHICLE_ROLES
from harness.options.suggest import did_you_mean
from harness.report.collisions import airframe_diameter_m
from harness.run.companion_args import DeclarationError, check_args, declared_params, program_module
from harness.scenarios.faults import Fault, FaultSpec, resolve_faults
from harness.sim.link_models import check_link_model, links_config
from sitl.links.config import LinksConfig
from sitl.power.loads import LOAD_PRESETS
from sitl.power.propulsion import load_power_spec
from sitl.vehicles.multirotor import airframe_yaml_path
from worlds.examples import EXAMPLE_PREFIX, world_path
from worlds.yaml_source import node_at, validate_yaml

DEFAULT_PARAMS: dict[str, float] = {"NAV_DLL_ACT": 2.0}
"""Autopilot parameters every scenario vehicle gets unless its role sets them: Return when the
companion falls silent (PX4's data-link-loss failsafe after COM_DL_LOSS_T without a HEARTBEAT;
PX4's own default, 0, would let a vehicle whose companion crashed hover until its battery ends)."""


PARAMS_ELSEWHERE = " (the autopilot's are in autopilot_emu/px4_params.yaml)"
"""Said of an unknown autopilot parameter with no close match (too many to list)."""

MAX_FULL_VEHICLES = 255
"""Vehicles of a ``fidelity: full`` fleet at most (MAVLink system ids 1..255)."""
MAX_SWARM_VEHICLES = 10_000
"""Vehicles of a ``fidelity: swarm`` fleet at most."""


class ScenarioError(ValueError):
    """A scenario that cannot run; the message names file, line and field where it can."""


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RoleSpec(_Model):
    """The companion program every vehicle of a role runs (one process per vehicle)."""

    module: str | None = None
    """Run ``python -m MODULE`` (e.g. ``companion.scripts.coverage``)."""
    script: str | None = None
    """Run ``python SCRIPT`` (a path relative to the scenario file)."""
    command: list[str] | None = None
    """Run this argv; ``{python}`` stands for the interpreter running swarmsitl."""
    args: dict[str, Any] = Field(default_factory=dict)
    """Passed to the program as JSON in ``SWARMSITL_PARAMS`` (``ScenarioEnv.params``)."""
    env: dict[str, str] = Field(default_factory=dict)
    """Extra environment variables of the program."""
    params: dict[str, float] = Field(default_factory=dict)
    """Autopilot parameters of this role's vehicles (over the airframe's and DEFAULT_PARAMS)."""

    @model_validator(mode="after")
    def _one_program(self) -> RoleSpec:
        given = [k for k in ("module", "script", "command") if getattr(self, k)]
        if len(given) > 1:
            raise ValueError(f"give one of module, script or command, not {' and '.join(given)}")
        return self

    @property
    def has_program(self) -> bool:
        """False for a role whose vehicles run no companion (they idle on the ground)."""
        return bool(self.module or self.script or self.command)


class FleetGroup(_Model):
    """``count`` vehicles of one airframe and role."""

    role: str
    count: int = Field(1, ge=1, le=MAX_SWARM_VEHICLES)
    """Vehicles of the group (at most 255 in the whole fleet at ``fidelity: full``: one MAVLink
    system id each)."""
    airframe: str = "typhoon_h480"
    """A folder of ``sitl/vehicles`` or the path of an airframe folder."""
    launch_area: str | None = None
    """Launch area of the world these vehicles start in [default: the scenario's]."""
    start_enu_m: list[tuple[float, float, float]] | None = None
    """Explicit start points (east, north, surface height; m), one per vehicle of the group."""
    node: str | None = None
    """Node-messaging role of these vehicles' companions (``edge``, ``fog``); docs/messaging.md."""
    battery_capacity_mah: float | list[float] | None = None
    """Capacity of the vehicles' LiPo packs, mAh: one for the group or one per vehicle; None: the
    airframe's pack (its ``power.battery.capacity_mah``)."""
    traits: dict[str, float | list[float]] = Field(default_factory=dict)
    """Free-form capabilities of the vehicles (``decision``, ``communication``,
    ``flight_time_s``, ...): one value for the group or a list of one per vehicle. The companions
    read them in ``ScenarioEnv.fleet``; the simulator does not."""
    priority: int | list[int] | None = None
    """The vehicles' priority (e.g. seed 001's ground-station priority for collision
    avoidance): one for the group or one per vehicle; None: each vehicle's number (1-based), so
    that every vehicle has a distinct one. Companions read it (``ScenarioEnv.fleet``,
    ``SwarmVehicle.priority``); the harness does not interpret it."""

    @model_validator(mode="after")
    def _starts(self) -> FleetGroup:
        if self.start_enu_m is not None and len(self.start_enu_m) != self.count:
            raise ValueError(
                f"start_enu_m has {len(self.start_enu_m)} points for count {self.count}"
            )
        cap = self.battery_capacity_mah
        if cap is not None:
            values = cap if isinstance(cap, list) else [cap]
            if isinstance(cap, list) and len(cap) != self.count:
                raise ValueError(
                    f"battery_capacity_mah has {len(cap)} values for count {self.count} "
                    "(give one for the group or one per vehicle)"
                )
            bad = [v for v in values if not v > 0.0]
            if bad:
                raise ValueError(f"battery_capacity_mah must be > 0 mAh, got {bad[0]!r}")
        if isinstance(self.priority, list) and len(self.priority) != self.count:
            raise ValueError(
                f"priority has {len(self.priority)} values for count {self.count} "
                "(give one for the group or one per vehicle)"
            )
        for name, value in self.traits.items():
            if isinstance(value, list) and len(value) != self.count:
                raise ValueError(
                    f"traits.{name} has {len(value)} values for count {self.count} "
                    "(give one for the group or one per vehicle)"
                )
        if self.node is not None and self.node not in VEHICLE_ROLES:
            hint = did_you_mean(self.node, VEHICLE_ROLES, listing="one of")
            raise ValueError(f"node: unknown role {self.node!r}{hint}")
        return self

    def battery_capacity_of(self, k: int) -> float | None:
        """The pack capacity the file gives the group's ``k``-th vehicle, mAh (None: airframe's)."""
        cap = self.battery_capacity_mah
        return float(cap[k]) if isinstance(cap, list) else None if cap is None else float(cap)

    def priority_of(self, k: int) -> int | None:
        """The priority the file gives the group's ``k``-th vehicle (None: its number)."""
        p = self.priority
        return int(p[k]) if isinstance(p, list) else None if p is None else int(p)

    def traits_of(self, k: int) -> dict[str, float]:
        """The traits of the group's ``k``-th vehicle."""
        return {
            name: float(v[k]) if isinstance(v, list) else float(v)
            for name, v in self.traits.items()
        }


class LinksSpec(_Model):
    """Link models of the MAVLink paths (docs/links.md)."""

    onboard: str = "none"
    """Companion <-> autopilot path: ``none`` (plain UDP), ``uart``, ... ."""
    gcs: str = "none"
    """Ground-station path (only with a ground-station port)."""
    file: str | None = None
    """Your link file, relative to the scenario file."""
    presets: dict[str, dict[str, Any]] = Field(default_factory=dict)
    """Link presets merged over the shipped ones and ``file``'s, as a link file's ``presets``
    (docs/links.md, "Inline presets in a scenario")."""
    classes: dict[str, str | None] = Field(default_factory=dict)
    """Link classes (``edge-edge: mesh``) over the shipped ones and ``file``'s, as a link file's
    ``classes``."""

    def inline(self) -> str | None:
        """``presets`` and ``classes`` as a link file's mapping in JSON text; None without any."""
        data = {k: v for k, v in (("presets", self.presets), ("classes", self.classes)) if v}
        return json.dumps(data, sort_keys=True) if data else None


class SensorsSpec(_Model):
    """Which simulated sensors run (both cost CPU only when on)."""

    cameras: bool = True
    rangefinders: bool = True
    camera_mount: Literal["down", "forward"] | None = None
    camera_size: str | None = Field(None, pattern=r"^\d+x\d+$")
    camera_hz: float | None = Field(None, gt=0)


class SwarmSpec(_Model):
    """The swarm-scale engine's settings (``fidelity: swarm``; docs/swarm.md)."""

    step_hz: float = Field(10.0, gt=0, le=1000)
    """Kinematic integration rate, steps per simulated second."""
    decision_hz: float = Field(1.0, gt=0)
    """How often every node's program decides (reads its messages, sets its target), Hz."""
    event_rate_hz: float = Field(0.0, ge=0)
    """Poisson events (targets appearing at random points of the area) per vehicle per
    simulated second (seed 000's event triggers); 0: only the world's targets."""
    neighbours: int = Field(6, ge=0, le=64)
    """Nearest nodes within radio range each node's neighbour table lists."""
    loads: str = "seed000_companion"
    """Electrical loads besides the rotors (``sitl.power.loads.LOAD_PRESETS``)."""
    link_range_m: float | None = Field(None, gt=0)
    """Range within which two airborne vehicles count as linked (the report's ``links_*``), m;
    None: the edge-edge link's range (as the neighbour tables)."""
    max_speed_m_s: float | None = Field(None, gt=0)
    """Horizontal speed limit of every vehicle, m/s, under its airframe's (the smaller of the
    two); None: the airframe's ``kinematics.max_speed_m_s``."""
    max_turn_rate_deg_s: float | None = Field(None, gt=0)
    """Largest change of course (the horizontal velocity's direction) per second of flight,
    deg/s, under the airframe's ``kinematics.max_turn_rate_deg_s`` (the smaller); None: the
    airframe's. Seed 001's "theta_max 30 deg" per one-second tick is 30."""

    @model_validator(mode="after")
    def _rates(self) -> SwarmSpec:
        if self.loads not in LOAD_PRESETS:
            hint = did_you_mean(self.loads, sorted(LOAD_PRESETS), listing="one of")
            raise ValueError(f"loads: unknown preset {self.loads!r}{hint}")
        ratio = self.step_hz / self.decision_hz
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"decision_hz {self.decision_hz:g} must divide step_hz {self.step_hz:g}"
            )
        return self


class ChecksSpec(_Model):
    """Pass/fail criteria evaluated on the finished run; ``swarmsitl run`` exits 1 if one fails."""

    companions_succeeded: bool = True
    """Every companion process exited with status 0."""
    landed_and_disarmed: bool = False
    """Every vehicle is on the ground and disarmed at the end."""
    no_failsafe: bool = False
    """No vehicle announced a failsafe."""
    min_separation_m: float | None = Field(None, gt=0)
    max_tilt_deg: float | None = Field(None, gt=0)
    stay_inside_world: bool = False
    """Every vehicle stayed inside the world's boundary."""
    max_collisions: int | None = Field(None, ge=0)
    """At most this many collision events (vehicle-vehicle and vehicle-solid; report
    ``fleet.collisions``, docs/swarm.md "Collisions"); 0: none allowed; None: not checked."""
    metrics: dict[str, tuple[float | None, float | None]] = Field(default_factory=dict)
    """``name: [min, max]`` bounds on report metrics (``null`` for no bound), e.g.
    ``fleet.spills_seen: [1, null]``."""


class ScenarioSpec(_Model):
    """The whole scenario file."""

    name: str
    description: str = ""
    fidelity: Literal["full", "swarm"] = "full"
    """``full``: PyBullet, one emulated autopilot and one companion process per vehicle;
    ``swarm``: vectorised kinematic vehicles, the companions' swarm programs in-process
    (docs/swarm.md)."""
    swarm: SwarmSpec = Field(default_factory=SwarmSpec)
    seed: int = Field(0, ge=0)
    """Seed of every random draw of the run (sensors, links); ``--seed`` overrides it."""
    duration_s: float = Field(gt=0)
    """Simulated seconds the run lasts at most."""
    world: str | dict[str, Any] | None = None
    """A world file (relative to the scenario file), ``example:KIND``, an inline world mapping,
    or none (a plain ground plane)."""
    reseed_world: bool = False
    """Build the world with the run's seed instead of the world file's (a new map per seed)."""
    launch_area: str | None = None
    """Where the fleet starts [default: the world's first launch area]."""
    spacing_m: Annotated[float, Field(gt=0)] = 5.0
    """Distance between vehicles at the start, m."""
    fleet: list[FleetGroup] = Field(min_length=1)
    roles: dict[str, RoleSpec] = Field(default_factory=dict)
    links: LinksSpec = Field(default_factory=LinksSpec)
    sensors: SensorsSpec = Field(default_factory=SensorsSpec)
    cloud: bool = False
    """With ``node`` roles in the fleet: also start the cloud node (a process)."""
    end_when_done: bool = True
    """Stop early once every companion has exited and every vehicle is disarmed."""
    swarm_prediction: bool = False
    """After a full-fidelity run, run the same scenario and seed at fidelity swarm too and set
    its battery, airborne time and distance per vehicle beside the flight model's (the report's
    ``swarm_prediction``; docs/swarm.md)."""
    camera_samples: int = Field(3, ge=0)
    """Camera images saved per vehicle (spread over the run) in ``camera/``."""
    checks: ChecksSpec = Field(default_factory=ChecksSpec)
    faults: list[FaultSpec] = Field(default_factory=list)
    """Vehicles that crash, land or lose their radio during the run (``harness.scenarios.faults``;
    docs/scenarios.md "Faults")."""

    @model_validator(mode="after")
    def _roles_have_programs(self) -> ScenarioSpec:
        missing = sorted({g.role for g in self.fleet} - set(self.roles))
        if missing:
            near = did_you_mean(missing[0], self.roles, listing="roles given")
            raise ValueError(
                f"roles: no entry for {', '.join(missing)} (a role without a program: "
                f"`{missing[0]}: {{}}`){near}"
            )
        if self.fidelity == "full" and self.n_vehicles > MAX_FULL_VEHICLES:
            raise ValueError(
                f"fleet: {self.n_vehicles} vehicles; fidelity full flies at most "
                f"{MAX_FULL_VEHICLES} (one MAVLink system id each): use fidelity: swarm"
            )
        nodes = {g.node is None for g in self.fleet}
        if len(nodes) > 1:
            raise ValueError("fleet: give every group a node role or none (node messaging)")
        return self

    @property
    def n_vehicles(self) -> int:
        """Vehicles in the fleet."""
        return sum(g.count for g in self.fleet)


@functools.lru_cache(maxsize=64)
def airframe_capacity_mah(airframe: str) -> float:
    """The capacity of an airframe's pack (its ``power.battery.capacity_mah``), mAh."""
    return load_power_spec(airframe_yaml_path(airframe)).battery.capacity_mah


@dataclass(frozen=True)
class Vehicle:
    """One vehicle of the fleet: its place in the scenario."""

    index: int
    """0-based; MAVLink system id index + 1."""
    group: FleetGroup
    role_index: int
    role_count: int
    group_index: int = 0
    """0-based index of the vehicle within its fleet group (for per-vehicle lists)."""

    @property
    def battery_capacity_override_mah(self) -> float | None:
        """The pack capacity the scenario gives this vehicle, mAh; None: its airframe's."""
        return self.group.battery_capacity_of(self.group_index)

    @property
    def battery_capacity_mah(self) -> float:
        """The vehicle's effective pack capacity, mAh (the scenario's, else the airframe's)."""
        cap = self.battery_capacity_override_mah
        return airframe_capacity_mah(self.group.airframe) if cap is None else cap

    @property
    def traits(self) -> dict[str, float]:
        """The vehicle's traits from its fleet group."""
        return self.group.traits_of(self.group_index)

    @property
    def priority(self) -> int:
        """The vehicle's priority: its group's, else its vehicle number (``index + 1``)."""
        p = self.group.priority_of(self.group_index)
        return self.index + 1 if p is None else p

    def fleet_entry(self) -> dict[str, Any]:
        """What the companions learn of this vehicle (one entry of ``SWARMSITL_FLEET``)."""
        return {
            "vehicle": self.index + 1,
            "role": self.group.role,
            "role_index": self.role_index,
            "airframe": self.group.airframe,
            "battery_capacity_mah": self.battery_capacity_mah,
            "traits": self.traits,
            "priority": self.priority,
            "diameter_m": round(airframe_diameter_m(self.group.airframe), 4),
        }


@dataclass(frozen=True)
class Scenario:
    """A validated scenario with its world built and paths resolved."""

    spec: ScenarioSpec
    path: Path | None
    """The scenario file (None for one parsed from a string)."""
    text: str
    """The file's text (copied to the run directory, hashed for the report)."""
    world_spec: worlds.WorldSpec | None
    world: worlds.World | None
    links_file: Path | None

    @property
    def vehicles(self) -> list[Vehicle]:
        """The fleet, vehicle by vehicle, in file order."""
        counts: dict[str, int] = {}
        for g in self.spec.fleet:
            counts[g.role] = counts.get(g.role, 0) + g.count
        seen: dict[str, int] = {}
        out = []
        for g in self.spec.fleet:
            for j in range(g.count):
                k = seen.get(g.role, 0)
                seen[g.role] = k + 1
                out.append(Vehicle(len(out), g, k, counts[g.role], j))
        return out

    @property
    def base_dir(self) -> Path:
        """Where relative paths of the file start."""
        return self.path.parent if self.path is not None else Path.cwd()

    def links_config(self) -> LinksConfig:
        """The run's link presets and classes: shipped, ``links.file``'s, then the inline ones.

        The one source of a scenario's link models (swarm engine, full stack, node messaging).
        """
        return links_config(self.links_file, self.spec.links.inline())

    def config_hash(self) -> str:
        """SHA-256 of the scenario text and the world spec (what determines the run with a seed)."""
        h = hashlib.sha256(self.text.encode())
        if self.world_spec is not None:
            h.update(json.dumps(self.world_spec.model_dump(mode="json"), sort_keys=True).encode())
        return h.hexdigest()

    def world_yaml(self) -> str | None:
        """The world spec of the run as YAML (``worlds.load_world`` reads it back)."""
        if self.world_spec is None:
            return None
        return yaml.safe_dump(self.world_spec.model_dump(mode="json"), sort_keys=False)

    def program(self, role: str) -> list[str] | None:
        """The argv of a role's companion; None for a role without one."""
        r = self.spec.roles[role]
        if r.module:
            return [sys.executable, "-m", r.module]
        if r.script:
            return [sys.executable, str((self.base_dir / r.script).resolve())]
        if r.command:
            return [sys.executable if a == "{python}" else a for a in r.command]
        return None

    def fleet_entries(self) -> tuple[dict[str, Any], ...]:
        """Every vehicle's ``Vehicle.fleet_entry``, in vehicle order (``ScenarioEnv.fleet``)."""
        return tuple(v.fleet_entry() for v in self.vehicles)

    def faults(self, seed: int) -> list[Fault]:
        """The run's faults with ``seed`` (the run's): vehicles and times drawn, by time."""
        return resolve_faults(self.spec.faults, self.spec.n_vehicles, seed)

    def params_of(self, vehicle: Vehicle) -> dict[str, float]:
        """Autopilot parameters of one vehicle: DEFAULT_PARAMS, BAT1_CAPACITY, then its role's.

        ``BAT1_CAPACITY`` is the vehicle's pack capacity when the scenario sets one.
        """
        cap = vehicle.battery_capacity_override_mah
        battery = {} if cap is None else {"BAT1_CAPACITY": cap}
        return DEFAULT_PARAMS | battery | dict(self.spec.roles[vehicle.group.role].params)


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The schema model of the scenario mapping at pydantic's ``loc`` (None: a free mapping)."""

    def unwrap(shape: Any) -> Any:
        if typing.get_origin(shape) is Annotated:
            return unwrap(typing.get_args(shape)[0])
        if typing.get_origin(shape) in (typing.Union, types.UnionType):
            members = [a for a in typing.get_args(shape) if a is not type(None)]
            return unwrap(members[0]) if len(members) == 1 else None
        return shape

    shape: Any = ScenarioSpec
    for part in loc:
        shape = unwrap(shape)
        if isinstance(shape, type) and issubclass(shape, BaseModel):
            field = shape.model_fields.get(str(part))
            shape = None if field is None else field.annotation
        elif typing.get_origin(shape) in (list, dict):
            shape = typing.get_args(shape)[-1]
        else:
            return None
    shape = unwrap(shape)
    return shape if isinstance(shape, type) and issubclass(shape, BaseModel) else None


def _schema_hint(error: dict[str, Any]) -> str:
    """An unknown key's close matches among the keys its section takes ("did you mean ...?")."""
    loc = tuple(error["loc"])
    if error["type"] != "extra_forbidden" or not loc:
        return ""
    model = _model_at(loc[:-1])
    return "" if model is None else did_you_mean(str(loc[-1]), model.model_fields)


def parse_scenario(text: str, source: str = "<string>", base_dir: Path | None = None) -> Scenario:
    """Validate scenario YAML ``text`` completely: :class:`ScenarioError` naming file and line."""
    spec: ScenarioSpec = validate_yaml(  # type: ignore[assignment]
        text,
        source,
        lambda data, root: ScenarioSpec,
        ScenarioError,
        "a scenario file is a mapping with at least name, duration_s, fleet and roles",
        hint=_schema_hint,
    )
    root = yaml.compose(text, Loader=yaml.SafeLoader)  # valid: validate_yaml parsed it
    base = (base_dir if base_dir is not None else Path.cwd()).absolute()

    def fail(loc: tuple[Any, ...], message: str) -> ScenarioError:
        node, _ = node_at(root, loc)
        field = ".".join(str(p) for p in loc)
        return ScenarioError(f"{source}:{node.start_mark.line + 1}: {field}: {message}")

    world_spec = _world_spec(spec, base, fail)
    world = None
    if world_spec is not None:
        if spec.reseed_world:
            world_spec = world_spec.model_copy(update={"seed": spec.seed})
        world = worlds.build(world_spec)
    links_file = None
    if spec.links.file is not None:
        links_file = (base / spec.links.file).resolve()
        if not links_file.is_file():
            raise fail(("links", "file"), f"no such file: {links_file}")
    try:
        links = links_config(links_file)
    except (OSError, ValueError) as exc:
        raise fail(("links", "file"), str(exc)) from exc
    if spec.links.inline() is not None:
        try:
            links = links_config(links_file, spec.links.inline())
        except ValueError as exc:  # the file alone was fine: the inline presets' field
            raise _inline_links_error(fail, str(exc)) from exc
    for key in ("onboard", "gcs"):
        try:
            check_link_model(getattr(spec.links, key), key, links)
        except ValueError as exc:
            raise fail(("links", key), str(exc).removeprefix(f"{key}: ")) from exc
    known_params = ParamStore().names
    for name, role in spec.roles.items():
        for p in role.params:
            if p not in known_params:
                hint = did_you_mean(p, known_params, otherwise=PARAMS_ELSEWHERE)
                raise fail(("roles", name, "params", p), f"unknown autopilot parameter{hint}")
        if role.script and not (base / role.script).is_file():
            raise fail(("roles", name, "script"), f"no such file: {(base / role.script)}")
        count = sum(g.count for g in spec.fleet if g.role == name)
        _check_role_args(name, role, base, fail, count, world)
    for k, group in enumerate(spec.fleet):
        try:
            airframe_yaml_path(group.airframe)
        except ValueError as exc:
            raise fail(("fleet", k, "airframe"), str(exc)) from exc
        area = group.launch_area or spec.launch_area
        if area is not None:
            if world is None:
                raise fail(("fleet", k, "launch_area"), "a launch area needs a world")
            try:
                world.launch_area(area)
            except KeyError as exc:
                loc = ("fleet", k, "launch_area") if group.launch_area else ("launch_area",)
                raise fail(loc, str(exc.args[0])) from exc
    for k, entry in enumerate(spec.faults):
        problem = entry.check_run(spec.n_vehicles, spec.duration_s)
        if problem is not None:
            raise fail(("faults", k, problem[0]), problem[1])
    return Scenario(spec, None, text, world_spec, world, links_file)


def _inline_links_error(fail: Any, message: str) -> ScenarioError:
    """A link error of the inline ``links.presets`` / ``links.classes``, at its field.

    The link loader's message starts with the field (``presets.mesh.range_m: must be ...``).
    """
    field, sep, rest = message.partition(": ")
    if sep and " " not in field and field.split(".")[0] in ("presets", "classes"):
        return fail(("links", *field.split(".")), rest)
    return fail(("links",), message)


def _check_role_args(
    name: str, role: RoleSpec, base: Path, fail: Any, count: int, world: worlds.World | None
) -> None:
    """The role's ``args`` read as its program reads them, if its module declares ``PARAMS``.

    A PARAMS dataclass with a ``check_run(vehicles, world)`` method (``RUN_CHECK``) is then
    asked whether it can serve the role's ``count`` vehicles in the scenario's world: a
    ValueError it raises fails the scenario here, before anything starts.
    """
    module = program_module(role.module, role.command)
    if module is None:
        return
    where = ("roles", name, "module" if role.module else "command")
    try:
        params = declared_params(module, base)
    except DeclarationError as exc:
        raise fail(where, str(exc)) from exc
    if params is None:
        return
    problem = check_args(params, role.args, module)
    if problem is not None:
        loc = ("roles", name, "args") + (() if problem.key is None else (problem.key,))
        raise fail(loc if role.args else where, problem.message)
    check = getattr(params, RUN_CHECK, None)
    if check is not None and count > 0:
        try:
            check(params_from_mapping(params, json.loads(json.dumps(dict(role.args)))), count,
                  world)  # fmt: skip
        except ValueError as exc:
            raise fail(("roles", name, "args") if role.args else where, str(exc)) from exc


def _world_spec(spec: ScenarioSpec, base: Path, fail: Any) -> worlds.WorldSpec | None:
    """The scenario's world spec from a path, ``example:KIND`` or an inline mapping."""
    if spec.world is None:
        return None
    try:
        if isinstance(spec.world, dict):
            return worlds.parse_world(yaml.safe_dump(spec.world), "world (inline)")
        if spec.world.startswith(EXAMPLE_PREFIX):
            try:
                return worlds.load_world(world_path(spec.world))
            except ValueError as exc:
                if isinstance(exc, worlds.WorldSpecError):
                    raise
                raise fail(("world",), str(exc)) from exc
        path = base / spec.world
        if not path.is_file():
            raise fail(("world",), f"no such world file: {path}")
        return worlds.load_world(path)
    except worlds.WorldSpecError as exc:
        raise ScenarioError(str(exc)) from exc


def load_scenario(path: str | Path) -> Scenario:
    """Read and completely validate the scenario file at ``path``."""
    path = Path(path).absolute()  # base_dir, and so every path the run hands on, is absolute
    try:
        text = path.read_text()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read scenario file: {exc}") from exc
    scenario = parse_scenario(text, str(path), path.parent)
    return Scenario(
        scenario.spec,
        path,
        text,
        scenario.world_spec,
        scenario.world,
        scenario.links_file,
    )
