"""One scenario run at ``fidelity: swarm``: the swarm-scale engine, then the report.

``run_swarm(scenario, seed, run_dir)`` builds the fleet from the scenario (the same start points
as the full stack, each airframe's kinematic limits), one messaging node per vehicle on a
:class:`~sitl.links.network.LinkNetwork` seeded with the run's seed, the world's targets and the
scenario's Poisson events, and each role's swarm program (``swarm_program`` of the role's
module), runs the engine in simulation time and returns the report: the same structure as a
full-stack run's (``vehicles``, ``fleet`` with ``companions`` totals and the roles' ``run``
metrics, ``faults`` (each injected fault with its simulated time), ``checks``, ``passed``), plus
``net`` (link metrics by class) and ``wall`` (wall-clock figures, which no comparison uses).
Same scenario and seed, same report apart from ``wall`` and ``wall_time_s``. docs/swarm.md.
"""

from __future__ import annotations

import importlib
import json
import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from companion.net.config import NetConfig, NodeSpec
from companion.net.node import Node
from companion.net.transport import PortTransport
from companion.scenario_env import ScenarioEnv
from harness.report.collisions import airframe_diameter_m
from harness.report.run_metrics import add_run_metrics
from harness.report.run_report import plot_tracks, quantity
from harness.report.totals import fleet_totals, metric_checks, versions
from harness.scenarios.fleet_spawn import fleet_spawn
from harness.scenarios.spec import Scenario, ScenarioError, SwarmSpec
from harness.swarm.engine import SwarmEngine, Target, poisson_events
from sitl.kinematic_fleet import KinematicFleet
from sitl.links.inprocess import InProcessPort
from sitl.links.network import LinkNetwork
from sitl.physics.earth import GRAVITY_M_S2
from sitl.power.hover_drain import HoverDrain
from sitl.power.loads import PayloadLoads
from sitl.power.propulsion import PowerSpec, load_power_spec
from sitl.vehicles.kinematics import KinematicLimits, load_kinematic_limits
from sitl.vehicles.multirotor import MultirotorSpec, load_airframe
from worlds.solid_set import SolidSet

AIR_DENSITY_KG_M3 = 1.225
"""ISA sea-level air density for the hover power, kg/m^3."""
PERSON_RADIUS_M = 0.5
"""A person seen from above, as a disc, m."""


def swarm_program_factory(scenario: Scenario, role: str) -> Any:
    """The ``swarm_program(env, vehicle, node)`` of a role's module.

    Raises:
        ScenarioError: the role runs a script or a command (no module to look in), or its module
            has no ``swarm_program`` (it has no kinematic adapter).
    """
    spec = scenario.spec.roles[role]
    if not spec.has_program:
        return None
    if spec.module is None:
        raise ScenarioError(
            f"roles.{role}: fidelity swarm runs a role's module in-process; "
            "a script or command role has none"
        )
    module = importlib.import_module(spec.module)
    factory = getattr(module, "swarm_program", None)
    if factory is None:
        raise ScenarioError(
            f"roles.{role}: module {spec.module} has no swarm_program(env, vehicle, node) "
            "(its kinematic adapter; docs/swarm.md), so it cannot run at fidelity swarm"
        )
    return factory


def _world_targets(scenario: Scenario) -> list[Target]:
    world = scenario.world
    if world is None:
        return []
    import worlds

    out = []
    for spill in world.targets_of(worlds.OilSpill):
        poly = spill.polygon
        c = poly.centroid
        out.append(Target(spill.name, (c.x, c.y), math.sqrt(poly.area / math.pi), spill.appear_s))
    for person in world.targets_of(worlds.Person):
        x, y, _ = person.position_enu_m
        out.append(Target(person.name, (x, y), PERSON_RADIUS_M, 0.0))
    return out


def hover_power_w(airframe: MultirotorSpec, power: PowerSpec) -> float:
    """Electrical power of the rotors in hover (momentum theory, the airframe's power block), W."""
    n = len(airframe.rotors)
    thrust = np.full(n, airframe.mass_kg * GRAVITY_M_S2 / n)
    return float(power.propulsion.hover_power_w(thrust, AIR_DENSITY_KG_M3))


def scenario_limits(limits: KinematicLimits, sw: SwarmSpec) -> KinematicLimits:
    """An airframe's limits capped by the scenario's ``swarm.max_speed_m_s`` and turn rate."""
    out = limits
    if sw.max_speed_m_s is not None:
        out = replace(out, max_speed_m_s=min(out.max_speed_m_s, sw.max_speed_m_s))
    if sw.max_turn_rate_deg_s is not None:
        turn = min(out.max_turn_rate_deg_s, sw.max_turn_rate_deg_s)
        out = replace(out, max_turn_rate_deg_s=turn)
    return out


def run_swarm(
    scenario: Scenario,
    seed: int | None = None,
    run_dir: Path | None = None,
    progress: Callable[[float], None] | None = None,
) -> dict:
    """Run ``scenario`` at swarm fidelity; return the report (and write it under ``run_dir``).

    ``progress(t)`` is called at each decision tick with the simulation time, s.

    Raises:
        ScenarioError: a role without a swarm program, an airframe without kinematic limits.
    """
    spec = scenario.spec
    seed = spec.seed if seed is None else int(seed)
    wall0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="swarmsitl-swarm-") as scratch:
        out = Path(run_dir) if run_dir is not None else Path(scratch)
        out.mkdir(parents=True, exist_ok=True)
        report = _run(scenario, seed, out, wall0, progress, write_files=run_dir is not None)
        if run_dir is not None:
            report["run_dir"] = str(out)
            (out / "report.json").write_text(json.dumps(report, indent=2, default=str) + "\n")
    return report


def _run(
    scenario: Scenario,
    seed: int,
    out: Path,
    wall0: float,
    progress: Callable[[float], None] | None,
    write_files: bool,
) -> dict:
    spec = scenario.spec
    sw = spec.swarm
    vehicles = scenario.vehicles
    n = len(vehicles)
    factories = {role: swarm_program_factory(scenario, role) for role in spec.roles}
    airframes: dict[str, MultirotorSpec] = {}
    limits: dict[str, KinematicLimits] = {}
    for g in spec.fleet:
        if g.airframe not in airframes:
            airframes[g.airframe] = load_airframe(g.airframe)
            try:
                limits[g.airframe] = scenario_limits(load_kinematic_limits(g.airframe), sw)
            except ValueError as exc:
                raise ScenarioError(f"fleet: airframe {g.airframe}: {exc}") from exc
    try:
        _, starts = fleet_spawn(scenario)
    except ValueError as exc:
        raise ScenarioError(f"fleet: {exc}") from exc
    fleet = KinematicFleet(starts, [limits[v.group.airframe] for v in vehicles])
    rng = np.random.default_rng(seed)
    world = scenario.world
    world_file = None
    if world is not None:
        world_file = out / "world.yaml"
        world_file.write_text(scenario.world_yaml() or "")
    if write_files:
        (out / "scenario.yaml").write_text(scenario.text)
    # targets: the world's, then the Poisson events over the world (or the fleet's square)
    if world is not None:
        bounds = tuple(float(b) for b in world.boundary.bounds)
        boundary = world.boundary

        def inside(xy: np.ndarray) -> np.ndarray:
            return shapely.contains_xy(boundary, xy[:, 0], xy[:, 1])
    else:
        lo, hi = starts[:, :2].min(axis=0) - 100.0, starts[:, :2].max(axis=0) + 100.0
        bounds = (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))
        inside = None  # type: ignore[assignment]
    events = poisson_events(sw.event_rate_hz * n, spec.duration_s, bounds, rng, inside)
    targets = _world_targets(scenario) + events
    cameras = spec.sensors.cameras
    tan_half = np.array(
        [
            math.tan(math.radians(airframes[v.group.airframe].camera.hfov_deg) / 2.0)
            if cameras and airframes[v.group.airframe].camera is not None
            else math.nan
            for v in vehicles
        ]
    )
    # messaging: one node per vehicle on the link network, in simulation time
    links = scenario.links_config()
    network = LinkNetwork(links, seed)
    node_ids = [f"vehicle{v.index + 1}" for v in vehicles]
    roles = [v.group.node or "edge" for v in vehicles]
    for node_id, role in zip(node_ids, roles, strict=True):
        network.add_node(node_id, role)
    edge_preset = links.classes.get("edge-edge")
    radio_range = links.presets[edge_preset].up.range_m if edge_preset else math.inf
    specs = {name: load_power_spec(a.yaml_path) for name, a in airframes.items()}
    hover_w = {name: hover_power_w(a, specs[name]) for name, a in airframes.items()}
    power = HoverDrain(
        [specs[v.group.airframe].battery for v in vehicles],
        [v.battery_capacity_mah for v in vehicles],
        [hover_w[v.group.airframe] for v in vehicles],
        [PayloadLoads.preset(sw.loads).total_w] * n,
    )
    clock = lambda: engine.time_s  # noqa: E731
    port = InProcessPort(network, clock)
    radius = np.array([airframe_diameter_m(v.group.airframe) / 2.0 for v in vehicles])
    engine = SwarmEngine(
        fleet, node_ids, sw.step_hz, sw.decision_hz, sw.neighbours, radio_range, tan_half,
        targets, inside if world is not None else None, power, sw.link_range_m,
        scenario.faults(seed), port.silence, radius,
        SolidSet(world.solids) if world is not None else None,
        [v.priority for v in vehicles],
    )  # fmt: skip
    config = NetConfig(
        {
            nid: NodeSpec(nid, role, ("127.0.0.1", 1 + i))
            for i, (nid, role) in enumerate(zip(node_ids, roles, strict=True))
        }
    )
    nodes = [Node(nid, config, PortTransport(port, nid), clock) for nid in node_ids]

    def place(e: SwarmEngine) -> None:
        pos = e.fleet.state.position_m
        for i, nid in enumerate(node_ids):
            network.set_position(nid, pos[i])

    engine.on_decision(place)
    if progress is not None:
        engine.on_decision(lambda e: progress(e.time_s))
    fleet_entries = scenario.fleet_entries()
    role_envs: dict[str, ScenarioEnv] = {}  # each role's first vehicle's, for run_metrics
    for v in vehicles:
        factory = factories[v.group.role]
        if factory is None:
            continue
        role = spec.roles[v.group.role]
        env = ScenarioEnv(
            mavlink_url="swarm://",
            grpc_port=0,
            vehicle=v.index + 1,
            vehicles=n,
            role=v.group.role,
            role_index=v.role_index,
            role_count=v.role_count,
            seed=seed,
            out_dir=out / node_ids[v.index],
            world=world_file,
            duration_s=spec.duration_s,
            params=dict(role.args),
            fleet=fleet_entries,
        )
        role_envs.setdefault(v.group.role, env)
        try:
            engine.programs[v.index] = factory(env, engine.handles[v.index], nodes[v.index])
        except Exception as exc:  # a program that cannot start fails its vehicle, not the run
            engine.stats.errors[v.index] = f"{type(exc).__name__}: {exc}"
    stop_reason = engine.run(spec.duration_s, spec.end_when_done)
    report = _report(scenario, seed, engine, network, port, stop_reason, role_envs)
    if write_files:  # a sweep's trial (no run directory) keeps only the report
        _write_outputs(report, scenario, engine, out)
    wall_s = time.monotonic() - wall0
    sim_s = engine.time_s
    st = engine.stats
    report["wall_time_s"] = wall_s
    report["real_time_factor"] = sim_s / wall_s if wall_s > 0 else None
    report["wall"] = {
        "decision_ms": 1e3 * st.decision_wall_s / st.decisions if st.decisions else None,
        "wall_s_per_sim_s": wall_s / sim_s if sim_s > 0 else None,
    }
    return report


def _report(
    scenario: Scenario, seed: int, engine: SwarmEngine, network: LinkNetwork,
    port: InProcessPort, stop_reason: str, role_envs: dict[str, ScenarioEnv],
) -> dict:  # fmt: skip
    spec = scenario.spec
    fleet = engine.fleet
    sim_s = engine.time_s
    power = engine.power
    assert power is not None
    remaining = power.remaining_pct
    vehicles: dict[str, Any] = {}
    for v in scenario.vehicles:
        i = v.index
        entry: dict[str, Any] = {
            "distance_flown": quantity(float(fleet.distance_m[i]), "m"),
            "airborne_time": quantity(float(fleet.airborne_s[i]), "s"),
            "max_tilt": quantity(math.degrees(float(fleet.max_tilt_rad[i])), "deg"),
            "energy": quantity(float(power.energy_j[i]), "J"),
            "battery_remaining": quantity(float(remaining[i]), "%"),
            "links_total": quantity(int(engine.links_total[i]), "count"),
            "collisions": quantity(int(engine.collisions.per_vehicle[i]), "count"),
            "landed": quantity(bool(not fleet.state.airborne[i]), "bool"),
        }
        program = engine.programs[i]
        if program is not None and getattr(program, "error", None):
            engine.stats.errors.setdefault(i, str(program.error))
        if program is not None:
            try:
                metrics = program.metrics()
                entry["companion"] = {
                    k: {"value": val, "unit": u} for k, (val, u) in metrics.items()
                }
            except Exception as exc:  # a broken metric must not cost the report
                engine.stats.errors.setdefault(i, f"metrics: {type(exc).__name__}: {exc}")
        if i in engine.stats.errors:
            entry["error"] = engine.stats.errors[i]
        vehicles[f"vehicle{i + 1}"] = entry
    st = engine.stats
    seen = st.first_seen_s
    appeared = [t for t in engine.targets if t.appear_s <= sim_s]
    latencies = [seen[t.name] - t.appear_s for t in appeared if t.name in seen]
    net = network.records(max(sim_s, 1e-9))
    delivered = sum(c["datagrams_delivered"] for c in net["classes"].values())
    submitted = sum(c["datagrams_submitted"] for c in net["classes"].values())
    carried = [c for c in net["classes"].values() if c["datagrams_delivered"]]
    latency_ms = (
        float(np.average([c["latency_ms"]["mean"] for c in carried],
                         weights=[c["datagrams_delivered"] for c in carried]))
        if carried else None
    )  # fmt: skip
    fleet_metrics = (
        {
            "vehicles": quantity(len(vehicles), "count"),
            "simulated_time": quantity(sim_s, "s"),
            "min_separation": quantity(_finite(st.min_separation_m), "m"),
            "min_separation_airborne": quantity(_finite(st.min_separation_airborne_m), "m"),
            "distance_flown": quantity(float(fleet.distance_m.sum()), "m"),
            "energy": quantity(float(power.energy_j.sum()), "J"),
            "battery_remaining_mean": quantity(float(remaining.mean()), "%"),
            "battery_remaining_min": quantity(float(remaining.min()), "%"),
            "decisions": quantity(st.decisions, "count"),
            "targets_appeared": quantity(len(appeared), "count"),
            "targets_seen": quantity(len(latencies), "count"),
            "detection_latency": quantity(float(np.mean(latencies)) if latencies else None, "s"),
            "datagrams_submitted": quantity(submitted, "count"),
            "datagrams_delivered": quantity(delivered, "count"),
            "message_loss": quantity(
                100.0 * (1 - delivered / submitted) if submitted else 0.0, "%"
            ),
            "message_latency": quantity(latency_ms, "ms"),
        }
        | _link_metrics(engine)
        | engine.collisions.fleet_metrics()
    )
    report: dict[str, Any] = {
        "scenario": spec.name,
        "fidelity": "swarm",
        "seed": seed,
        "complete": stop_reason in ("duration", "done"),
        "stop_reason": stop_reason,
        "mode": "lockstep",
        "sim_time_s": sim_s,
        "config_hash": scenario.config_hash(),
        "versions": versions(),
        "vehicles": vehicles,
        "fleet": fleet_metrics,
        "net": net,
        "warnings": [],
    }
    report["faults"] = engine.fault_records + engine.pending_fault_records()
    for record in engine.fault_records:
        entry = vehicles[record["vehicle"]]
        entry["fault"] = "+".join(filter(None, (entry.get("fault"), record["kind"])))
    report["fleet"]["datagrams_dropped_by_faults"] = quantity(
        sum(port.fault_drops.values()), "count"
    )
    report["fleet"]["companions"] = fleet_totals(report)
    report["checks"] = _checks(scenario, engine)
    add_run_metrics(report, scenario, role_envs)
    if spec.checks.metrics:
        report["checks"] |= metric_checks(report, spec.checks.metrics)
    if spec.checks.no_failsafe:
        report["warnings"].append("checks.no_failsafe: fidelity swarm models no failsafes")
    if spec.cloud:
        report["warnings"].append("cloud: fidelity swarm starts no cloud process")
    cut = np.flatnonzero(np.isfinite(power.cutoff_at_s))
    if len(cut):
        report["warnings"].append(
            f"battery: {len(cut)} vehicles' packs fell under the low-voltage cutoff (vehicles "
            + ", ".join(f"{i + 1} at {power.cutoff_at_s[i]:.0f} s" for i in cut[:10])
            + "); fidelity swarm flies them on, their remaining charge clamps at 0 %"
        )
    report["passed"] = report["complete"] and all(c["ok"] for c in report["checks"].values())
    return report


def _link_metrics(engine: SwarmEngine) -> dict[str, Any]:
    """Links within range and active vehicles over the run (the fleet's ``links_*`` keys)."""
    decisions = engine.stats.link_decisions
    active = np.array(engine.series_active[:decisions])
    links_mean = np.array(engine.series_links_mean[:decisions])
    flying = active > 0
    if engine.fleet.state.airborne.any():
        mission_s: float | None = engine.time_s
    else:
        mission_s = engine.stats.last_landing_s
    return {
        "links_per_agent_mean": quantity(float(engine.links_total.mean()), "count"),
        "links_per_step_mean": quantity(
            float(links_mean[flying].mean()) if flying.any() else 0.0, "count"
        ),
        "active_max": quantity(int(active.max()) if decisions else 0, "count"),
        "mission_time": quantity(mission_s, "s"),
    }


def _write_outputs(report: dict, scenario: Scenario, engine: SwarmEngine, out: Path) -> None:
    """tracks.npz and plots/map.png beside the report; their names go to ``report["files"]``.

    The link series (one entry per position sample) also go to ``report["series"]``.
    """
    tracks = np.array(engine.samples)
    np.savez_compressed(
        out / "tracks.npz",
        time_s=np.array(engine.series_time_s),
        position_enu_m=tracks,
        active=np.array(engine.series_active),
        links_mean=np.array(engine.series_links_mean),
    )
    report["series"] = {
        "time_s": list(engine.series_time_s),
        "active": list(engine.series_active),
        "links_mean": list(engine.series_links_mean),
    }
    report["files"] = ["report.json", "tracks.npz", "scenario.yaml"]
    if scenario.world is not None:
        report["files"].append("world.yaml")
    try:
        (out / "plots").mkdir(exist_ok=True)
        plot_tracks(out / "plots" / "map.png", tracks, scenario.world, report.get("seed"))
        report["files"].append("plots/map.png")
    except Exception as exc:  # a failed plot must not cost the report
        report["warnings"].append(f"plots/map.png not written: {exc!r}")


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _checks(scenario: Scenario, engine: SwarmEngine) -> dict[str, dict[str, Any]]:
    checks = scenario.spec.checks
    st = engine.stats
    fleet = engine.fleet
    out: dict[str, dict[str, Any]] = {}
    if checks.companions_succeeded:
        bad = sorted(st.errors)
        out["companions_succeeded"] = {
            "ok": not bad,
            "value": len(bad),
            "message": "; ".join(f"vehicle {i + 1}: {st.errors[i]}" for i in bad[:10])
            or "every swarm program finished without an error",
        }
    if checks.landed_and_disarmed:
        up = np.flatnonzero(fleet.state.airborne)
        out["landed_and_disarmed"] = {
            "ok": len(up) == 0,
            "value": len(up),
            "message": f"{len(up)} vehicles still airborne at the end"
            if len(up)
            else f"all {fleet.n} vehicles landed at the end",
        }
    if checks.min_separation_m is not None:
        d = st.min_separation_airborne_m
        out["min_separation"] = {
            "ok": not d < checks.min_separation_m,
            "value": _finite(d),
            "message": f"closest approach of airborne vehicles {d:.2f} m (at least "
            f"{checks.min_separation_m:g} m)",
        }
    if checks.max_tilt_deg is not None:
        tilt = math.degrees(float(fleet.max_tilt_rad.max()))
        out["max_tilt"] = {
            "ok": tilt <= checks.max_tilt_deg,
            "value": round(tilt, 4),
            "message": f"max tilt {tilt:.1f} deg (the accelerations' tilt), limit "
            f"{checks.max_tilt_deg:g} deg",
        }
    if checks.max_collisions is not None:
        out["max_collisions"] = engine.collisions.check(checks.max_collisions)
    if checks.stay_inside_world and scenario.world is not None:
        outside = sorted(st.outside_world)
        out["stay_inside_world"] = {
            "ok": not outside,
            "value": len(outside),
            "message": "every vehicle stayed inside the polygon"
            if not outside
            else f"vehicles {[i + 1 for i in outside[:10]]} left the world",
        }
    return out
