"""Running a scenario: simulation, emulated autopilots, one companion process per vehicle, report.

:class:`ScenarioRun` composes what ``swarmsitl up`` composes (world, fleet, MAVLink links, link
models, node messaging), starts each vehicle's companion program as its own process (it reaches
its vehicle only through MAVLink, and other companions only through ``companion.net``), drives the
simulation paced or in lockstep, and writes the run directory (``docs/scenarios.md``): tlogs and
truth while it runs; manifest, report, time series, plots and camera samples at the end, also
after Ctrl-C (marked incomplete) or a crashed companion (its traceback is in the report, its
vehicle's autopilot runs PX4's data-link-loss failsafe).

Faults (the scenario's ``faults:``, drawn from the run's seed) are applied inside the simulation's
step, in simulated time (:mod:`harness.scenarios.fault_injection`); the report lists them
(``faults``) and marks each faulted vehicle (``vehicles.vehicleN.fault``). A vehicle a fault
took (crash, land) is not held to what its flight can no longer do: ``landed_and_disarmed``
asks a crashed vehicle only to be disarmed (termination disarms it; it may still be falling
when a late crash ends the run); ``no_failsafe`` leaves out what a lost vehicle announces from
its fault on (the injected termination is no failsafe text anyway); ``companions_succeeded``
accepts a failed exit of a lost vehicle's companion noticed after the fault (its program found
a vehicle that would no longer fly); a failure before the fault still fails the run.

Time: the simulation's clock is published to the companions in ``SWARMSITL_CLOCK_FILE``
(``companion.clock``), paced or not. A lockstep run goes as fast as its slowest live
participant allows once every companion has reached its vehicle (:mod:`harness.run.lockstep`: the
companions' clock acknowledgements, their ``mavsdk_server``'s PING echoes and heartbeats, their
processes' stops); until then it runs at real time, so that a program starting up (MAVSDK's
server takes a wall second or two) does not miss the first simulated minute.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime as dt
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from companion.scenario_env import ScenarioEnv
from harness.net.plan import NetPlan, NetRun
from harness.net.roles import attach, role_process
from harness.net.roles import write_report as write_net_report
from harness.report.collisions import CollisionCounter, scenario_collisions
from harness.report.flight_checks import (
    landed_and_disarmed,
    max_tilt,
    min_separation,
    no_failsafe,
    stayed_inside,
)
from harness.report.flight_log import FlightLog
from harness.report.run_metrics import add_run_metrics
from harness.report.run_report import write_run_report
from harness.report.swarm_prediction import swarm_prediction
from harness.report.totals import fleet_totals, metric_checks, versions
from harness.run.lockstep import LOCKSTEP, GatedLink, LockstepGate, gated_links
from harness.run.manifest import RunManifest, write_manifest
from harness.run.ports import RunPorts, free_tcp_ports
from harness.run.session import RunSession
from harness.scenarios.fault_injection import FaultInjector
from harness.scenarios.fleet_spawn import fleet_spawn
from harness.scenarios.spec import Scenario
from harness.sim.simulation import PortPlan, Simulation, SimulationConfig
from harness.sim.world_setup import WorldSetup, world_config
from sitl.sensors.camera import CameraFrame, with_mount
from sitl.vehicles.multirotor import load_airframe

CHECK_EVERY_S = 0.1
"""How often the loop looks at the companions and the stop conditions, simulated s."""
DONE_HOLD_S = 2.0
"""Companions all exited and every vehicle disarmed for this long: the run is done, s."""
TRACEBACK_CHARS = 6000
"""Longest traceback kept in the report per companion."""
STOP_GRACE_S = 5.0
"""Wall seconds a companion gets to exit after SIGTERM before it is killed."""


@dataclass(frozen=True)
class RunOptions:
    """How to run a scenario (``swarmsitl run`` options)."""

    out_dir: Path
    seed: int | None = None
    """Overrides the scenario's seed."""
    speed: float | None = None
    """Simulated seconds per wall second; None: lockstep (as fast as possible)."""
    ports: RunPorts = field(default_factory=RunPorts)
    timeout_wall_s: float | None = None
    """Give up (report incomplete) after this many wall seconds."""


@dataclass
class Companion:
    """One vehicle's companion process."""

    vehicle: int
    role: str
    argv: list[str]
    log_path: Path
    process: subprocess.Popen
    exit_code: int | None = None
    exit_time_s: float | None = None
    """Simulation time the exit was noticed, s."""

    def poll(self, now_s: float) -> bool:
        """True while it runs; notes the exit code and time once it ended."""
        if self.exit_code is None:
            code = self.process.poll()
            if code is None:
                return True
            self.exit_code, self.exit_time_s = code, now_s
        return False

    def summary(self) -> dict[str, Any]:
        """What the report says about it: command, exit, log, traceback of a failure."""
        out: dict[str, Any] = {
            "role": self.role,
            "command": self.argv,
            "exit_code": self.exit_code,
            "exit_time_s": self.exit_time_s,
            "log": str(self.log_path),
        }
        if self.exit_code not in (0, None):
            out["traceback"] = traceback_in(self.log_path)
        return out


TRACEBACK_HEAD = "Traceback (most recent call last):"


def traceback_in(log_path: Path) -> str | None:
    """The first Python traceback in a companion's log, or its tail when there is none.

    The first, because what a crashing program prints later (libraries failing while the
    interpreter shuts down) follows from it.
    """
    try:
        text = log_path.read_text(errors="replace")
    except OSError:
        return None
    start = text.find(TRACEBACK_HEAD)
    if start < 0:
        return text[-2000:] or None
    end = text.find(TRACEBACK_HEAD, start + len(TRACEBACK_HEAD))
    body = text[start:] if end < 0 else text[start:end]
    return body[:TRACEBACK_CHARS]


def finish_report(
    report: dict[str, Any], scenario: Scenario, role_envs: dict[str, ScenarioEnv]
) -> None:
    """Add a full-stack report's run-wide parts, in place.

    The companions' fleet totals, the roles' ``run_metrics`` (``fleet.run``), the
    ``checks.metrics`` bounds, then ``passed``.
    """
    report.setdefault("fleet", {})["companions"] = fleet_totals(report)
    add_run_metrics(report, scenario, role_envs)
    checks = report.setdefault("checks", {})
    bounds = scenario.spec.checks.metrics
    if bounds:
        checks |= metric_checks(report, bounds)
    report["passed"] = bool(report.get("complete")) and all(c["ok"] for c in checks.values())


class ScenarioRun:
    """One run of a scenario; ``run()`` returns the report (a dict, also in report.json)."""

    def __init__(self, scenario: Scenario, options: RunOptions) -> None:
        self.scenario = scenario
        self.options = options
        spec = scenario.spec
        self.seed = spec.seed if options.seed is None else options.seed
        self.run_dir = options.out_dir.absolute()  # companions start in other directories
        self.vehicles = scenario.vehicles
        self.fleet_entries = scenario.fleet_entries()
        """What every companion learns of the fleet (``ScenarioEnv.fleet``)."""
        self.companions: list[Companion] = []
        self.session: RunSession | None = None
        """The run's lifecycle (simulation, clock file, acknowledgements, the cloud and bridge
        processes); the companions' process groups are this runner's to stop."""
        self.stop_reason = "duration"
        self.stop_requested = False
        self.wall_start = time.monotonic()
        self.started_utc = dt.datetime.now(dt.UTC).isoformat(timespec="seconds")
        self._samples: dict[int, list[float]] = {}
        self._gate: LockstepGate | None = None
        self.sim: Simulation | None = None
        self.manifest: RunManifest | None = None
        self._grpc_ports: list[int] = []
        """Each vehicle's companion's mavsdk_server port (the base's, or the next free ones)."""
        self.role_envs: dict[str, ScenarioEnv] = {}
        """Each role's first started companion's environment (``run_metrics``)."""
        self.net_run: NetRun | None = None
        self.faults = scenario.faults(self.seed)
        """The run's faults (``faults:`` with the run's seed), in time order."""
        self.injector: FaultInjector | None = None
        """Applies them in the simulation's step and notes when (once the simulation runs)."""
        self.setup: WorldSetup | None
        """What the world asks of the simulation (scene, spawn points, wind, mocap, params)."""
        self.spawn_enu_m: Any
        """Start point (east, north, surface height) of every vehicle, m."""
        self.setup, self.spawn_enu_m = fleet_spawn(scenario)

    # ---- setup -------------------------------------------------------------------------------

    def _simulation_config(self) -> SimulationConfig:
        spec, scenario = self.scenario.spec, self.scenario
        ports = self.options.ports
        frames = tuple(v.group.airframe for v in self.vehicles)
        setup, sensors = self.setup, spec.sensors
        world = world_config(
            spec.n_vehicles,
            setup,
            spawn_enu_m=tuple(tuple(p) for p in self.spawn_enu_m),
            rangefinders=sensors.rangefinders,
            cameras=sensors.cameras,
            camera=self._cameras(frames) if sensors.cameras else None,
            battery_capacity_mah=tuple(v.battery_capacity_override_mah for v in self.vehicles),
        )
        return SimulationConfig(
            n_vehicles=spec.n_vehicles,
            seed=self.seed,
            frames=frames,
            spacing_m=spec.spacing_m,
            ports=PortPlan(
                sdk_base=ports.sdk,
                listen_base=ports.listen,
                gcs_port=0,
                video_base=0,
                payload_listen_base=0,
                payload_base=ports.payload,
            ),
            out_dir=self.run_dir,
            mocap_port=ports.mocap,
            wind=setup.wind if setup is not None else None,
            world=world,
            params=dict(setup.params) if setup is not None else {},
            vehicle_params=tuple(scenario.params_of(v) for v in self.vehicles),
            onboard_link=spec.links.onboard,
            gcs_link=spec.links.gcs,
            links=scenario.links_config(),
            router=self.net_run.router if self.net_run is not None else None,
            ping_period_s=LOCKSTEP.ping_period_s if self.options.speed is None else 0.0,
        )

    def _cameras(self, frames: tuple[str, ...]) -> tuple | None:
        """Each vehicle's camera with the scenario's sensor overrides; None: the airframes'."""
        s = self.scenario.spec.sensors
        if s.camera_mount is None and s.camera_size is None and s.camera_hz is None:
            return None
        changes: dict[str, Any] = {}
        if s.camera_size is not None:
            w, h = s.camera_size.split("x")
            changes |= {"width_px": int(w), "height_px": int(h)}
        if s.camera_hz is not None:
            changes["rate_hz"] = s.camera_hz
        out = []
        for name in frames:
            cam = load_airframe(name).camera
            if cam is not None:
                cam = dataclasses.replace(cam, **changes)
                cam = with_mount(cam, s.camera_mount) if s.camera_mount else cam
            out.append(cam)
        return tuple(out)

    def _prepare_dir(self) -> None:
        self.run_dir.mkdir(parents=True, exist_ok=True)
        (self.run_dir / "scenario.yaml").write_text(self.scenario.text)
        world_yaml = self.scenario.world_yaml()
        if world_yaml is not None:
            (self.run_dir / "world.yaml").write_text(world_yaml)

    def _start_net(self) -> None:
        spec = self.scenario.spec
        if spec.fleet[0].node is None:
            return
        plan = NetPlan(
            tuple(v.group.node for v in self.vehicles),  # type: ignore[misc]
            cloud=spec.cloud,
            node_base=self.options.ports.net,
            proxy_base=self.options.ports.net_proxy,
            links=self.scenario.links_config(),
        )
        self.net_run = NetRun(plan, self.seed, self.run_dir)

    def _env(self, v: Any, node_of: dict[int, str]) -> dict[str, str]:
        sim = self.sim
        assert sim is not None
        cfg = sim.world.config
        role = self.scenario.spec.roles[v.group.role]
        senv = ScenarioEnv(
            mavlink_url=f"udpin://0.0.0.0:{sim.config.ports.sdk_port(v.index)}",
            grpc_port=self._grpc_ports[v.index],
            vehicle=v.index + 1,
            vehicles=len(self.vehicles),
            role=v.group.role,
            role_index=v.role_index,
            role_count=v.role_count,
            seed=self.seed,
            out_dir=self.run_dir / f"vehicle{v.index + 1}",
            world=(self.run_dir / "world.yaml") if self.scenario.world_spec is not None else None,
            origin=(cfg.origin_lat_deg, cfg.origin_lon_deg, cfg.origin_alt_amsl_m),
            video_uri=sim.video_uris[v.index],
            duration_s=self.scenario.spec.duration_s,
            params=role.args,
            fleet=self.fleet_entries,
        )
        self.role_envs.setdefault(v.group.role, senv)
        env = dict(os.environ) | senv.to_env() | dict(role.env)
        env |= {"PYTHONUNBUFFERED": "1", "SWARMSITL_CLOCK_FILE": str(self.session.clock.path)}
        if self.options.speed is not None:
            env |= {
                "SWARMSITL_SPEED": f"{self.options.speed:g}",
                "SWARMSITL_CLOCK_ORIGIN": repr(self.wall_start),
            }
        if self.net_run is not None and v.index in node_of:
            env |= self.net_run.env(node_of[v.index])
        return env

    def _start_companions(self) -> None:
        self._grpc_ports = free_tcp_ports(self.options.ports.grpc, len(self.vehicles))
        node_of = {}
        if self.net_run is not None:
            node_of = {n.vehicle: n.node_id for n in self.net_run.nodes if n.vehicle is not None}
        for v in self.vehicles:
            argv = self.scenario.program(v.group.role)
            if argv is None:
                continue
            out = self.run_dir / f"vehicle{v.index + 1}"
            out.mkdir(parents=True, exist_ok=True)
            log_path = out / "companion.log"
            with log_path.open("w") as log:
                proc = subprocess.Popen(
                    argv,
                    stdout=log,
                    stderr=subprocess.STDOUT,
                    env=self._env(v, node_of),
                    cwd=self.scenario.base_dir,
                    start_new_session=True,  # Ctrl-C reaches the runner, which stops them
                )
            self.companions.append(Companion(v.index, v.group.role, argv, log_path, proc))

    def _start_bridges(self) -> None:
        """GPS-denied worlds: the mocap bridge each vehicle's companion computer runs."""
        if self.setup is None or not self.setup.bridge:
            return
        sim = self.sim
        assert sim is not None
        ports = sim.config.ports
        for i in range(len(self.vehicles)):
            out = self.run_dir / f"vehicle{i + 1}"
            out.mkdir(parents=True, exist_ok=True)
            argv = [
                sys.executable, "-m", "companion.scripts.mocap_bridge", "--vehicle", str(i),
                "--listen", f"{ports.peer_addr}:{sim.config.mocap_port + i}",
                "--mavlink", f"udpout:{ports.bind_addr}:{ports.listen_port(i)}",
            ]  # fmt: skip
            with (out / "mocap_bridge.log").open("w") as log:
                bridge = subprocess.Popen(
                    argv, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
                )
            self.session.adopt_process(f"mocap_bridge{i + 1}", bridge)

    # ---- running -----------------------------------------------------------------------------

    def request_stop(self, reason: str = "interrupted") -> None:
        """Stop at the next check (a signal handler may call it)."""
        if not self.stop_requested:
            self.stop_requested = True
            self.stop_reason = reason

    def _sample_frames(self, frames: list[CameraFrame]) -> None:
        """Save the camera images due at the scenario's sample times as PNG."""
        import cv2

        for frame in frames:
            due = self._samples.get(frame.vehicle)
            if due and frame.time_s >= due[0]:
                due.pop(0)
                name = f"vehicle{frame.vehicle + 1}_t{frame.time_s:06.1f}.png"
                path = self.run_dir / "camera" / name
                path.parent.mkdir(exist_ok=True)
                cv2.imwrite(str(path), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))

    def _heard_all(self) -> bool:
        """Every running companion's vehicle received a MAVLink frame from it."""
        sim = self.sim
        assert sim is not None
        ports = sim.config.ports
        heard = {
            i
            for i in range(len(self.vehicles))
            for ep in sim.endpoints
            if ep.local_address[1] == ports.listen_port(i) and ep.stats.frames_received > 0
        }
        return all(c.vehicle in heard or c.exit_code is not None for c in self.companions)

    def _done(self, disarmed_since: list[float | None]) -> bool:
        sim = self.sim
        assert sim is not None
        if not self.scenario.spec.end_when_done or not self.companions:
            return False
        if any(c.exit_code is None for c in self.companions):
            disarmed_since[0] = None
            return False
        if any(c.armed for c in sim.fleet.commanders):
            disarmed_since[0] = None
            return False
        if disarmed_since[0] is None:
            disarmed_since[0] = sim.time_s
        return sim.time_s - disarmed_since[0] >= DONE_HOLD_S

    def _gated_links(self) -> list[GatedLink]:
        """The onboard links of the vehicles whose companion still runs."""
        assert self.sim is not None
        return gated_links(self.sim, [c.vehicle for c in self.companions if c.exit_code is None])

    def _live_groups(self) -> list[int]:
        """Process groups of the companions that still run (each started its own session)."""
        return [c.process.pid for c in self.companions if c.exit_code is None]

    def _give_up(self) -> bool:
        """While the lockstep waits: notice ended companions, a stop request, the wall timeout."""
        now = self.sim.time_s if self.sim is not None else 0.0
        for c in self.companions:
            c.poll(now)
        timeout = self.options.timeout_wall_s
        if timeout is not None and time.monotonic() - self.wall_start > timeout:
            self.request_stop("timeout")
        return self.stop_requested

    def _loop(self, on_progress: Callable[[ScenarioRun], None] | None) -> None:
        sim = self.sim
        assert sim is not None and self.session is not None
        clock = self.session.clock
        end = self.scenario.spec.duration_s
        steps = max(1, round(sim.config.physics_hz * CHECK_EVERY_S))
        speed = self.options.speed
        warmed = speed is not None
        t0_sim, t0_wall = sim.time_s, time.monotonic()
        disarmed_since: list[float | None] = [None]
        timeout = self.options.timeout_wall_s
        while sim.time_s < end - 1e-9 and not self.stop_requested:
            if self._gate is not None and warmed:
                self._gate.hold(sim, min(sim.time_s + CHECK_EVERY_S, end), self._give_up)
                if self.stop_requested:
                    break
            for _ in range(steps):
                sim.step()
                clock.publish(sim.time_s)
                if sim.time_s >= end - 1e-9:
                    break
            for c in self.companions:
                c.poll(sim.time_s)
            if on_progress is not None:
                on_progress(self)
            if self._done(disarmed_since):
                self.stop_reason = "done"
                break
            if timeout is not None and time.monotonic() - self.wall_start > timeout:
                self.request_stop("timeout")
                break
            if not warmed and self._heard_all():
                warmed = True
                t0_sim, t0_wall = sim.time_s, time.monotonic()  # the cap counts from here
            pace = speed if speed is not None else (None if warmed else 1.0)
            if pace is not None:
                ahead = (sim.time_s - t0_sim) / pace - (time.monotonic() - t0_wall)
                if ahead > 0.0005:
                    time.sleep(ahead)
            else:
                t0_sim, t0_wall = sim.time_s, time.monotonic()

    def run(self, on_progress: Callable[[ScenarioRun], None] | None = None) -> dict[str, Any]:
        """Start everything, run, stop everything, write the report; returns it."""
        self._prepare_dir()
        spec = self.scenario.spec
        try:
            self._start_net()
            self.sim = Simulation(self._simulation_config())
            self.manifest = RunManifest.from_simulation(
                self.sim,
                spec.duration_s,
                tuple(v.group.role for v in self.vehicles),
                "world.yaml" if self.scenario.world_spec is not None else None,
            )
            write_manifest(self.run_dir, self.manifest)
            n = spec.camera_samples
            self._samples = {
                i: [spec.duration_s * (k + 1) / (n + 1) for k in range(n)]
                for i, cam in enumerate(self.sim.world.camera_specs)
                if cam is not None
            }
            if self._samples:
                self.sim.on_frames(self._sample_frames)
            if self.net_run is not None:
                attach(self.net_run, self.sim)
            nodes = {}
            if self.net_run is not None:
                nodes = {n.vehicle: n.node_id for n in self.net_run.nodes if n.vehicle is not None}
            self.injector = FaultInjector(self.faults, self.sim, nodes)
            # The signals are the caller's (``swarmsitl run`` calls request_stop).
            session = RunSession(
                self.sim, self.run_dir, speed=self.options.speed, handle_signals=False
            )
            self.session = session
            if session.acks is not None:
                self._gate = LockstepGate(
                    LOCKSTEP, session.acks, self._gated_links, self._live_groups
                )
            self.wall_start = session.wall_start_s
            if self.net_run is not None and spec.cloud:
                cloud = role_process(
                    self.net_run, "cloud", spec.duration_s, self.options.speed or 1.0,
                    self.wall_start, self.run_dir / "cloud.log", clock_file=session.clock.path,
                )  # fmt: skip
                session.adopt_process("cloud", cloud)
            self._start_bridges()
            self._start_companions()
            self._loop(on_progress)
        finally:
            self._stop_companions()
            if self.session is not None:
                self.session.close()  # the cloud, tlogs, truth.csv, the clock, the acks
            elif self.sim is not None:
                self.sim.close()
        return self._finish()

    def _stop_companions(self) -> None:
        """SIGTERM every companion's process group (its mavsdk_server too), kill after grace."""
        now = self.sim.time_s if self.sim is not None else 0.0
        live = [c for c in self.companions if c.poll(now)]
        for c in live:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(c.process.pid, signal.SIGTERM)
        deadline = time.monotonic() + STOP_GRACE_S
        for c in live:
            try:
                c.process.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(c.process.pid, signal.SIGKILL)
                c.process.wait()
            c.exit_code = c.process.returncode
            c.exit_time_s = now
        for c in self.companions:  # a companion's leftover children (mavsdk_server)
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(c.process.pid, signal.SIGKILL)

    # ---- report ------------------------------------------------------------------------------

    def _checks(self, log: FlightLog, collisions: CollisionCounter) -> dict[str, dict[str, Any]]:
        checks = self.scenario.spec.checks
        out: dict[str, dict[str, Any]] = {}

        def put(name: str, result: Any) -> None:
            out[name] = {"ok": bool(result.ok), "value": result.value, "message": result.message}

        lost = self.injector.lost() if self.injector is not None else {}
        crashed = self.injector.lost("crash") if self.injector is not None else {}
        if checks.companions_succeeded:
            out["companions_succeeded"] = self._companions_check(lost)
        if checks.landed_and_disarmed:
            put("landed_and_disarmed", landed_and_disarmed(log, crashed=tuple(crashed)))
        if checks.no_failsafe:
            put("no_failsafe", no_failsafe(log, excused_from_s=lost))
        if checks.min_separation_m is not None:
            put("min_separation", min_separation(log, checks.min_separation_m))
        if checks.max_tilt_deg is not None:
            put("max_tilt", max_tilt(log, checks.max_tilt_deg))
        if checks.stay_inside_world and self.scenario.world is not None:
            put("stay_inside_world", stayed_inside(log, self.scenario.world.boundary))
        if checks.max_collisions is not None:
            out["max_collisions"] = collisions.check(checks.max_collisions)
        return out

    def _companions_check(self, lost: dict[int, float]) -> dict[str, Any]:
        """Every companion exited with 0, or failed only after a fault took its vehicle."""
        bad, excused = [], []
        for c in self.companions:
            if c.exit_code == 0:
                continue
            since = lost.get(c.vehicle)
            late = since is not None and c.exit_code is not None and c.exit_time_s is not None
            (excused if late and c.exit_time_s >= since else bad).append(c)
        notes = [f"vehicle {c.vehicle + 1} ({c.role}) exited with {c.exit_code}" for c in bad]
        notes += [
            f"vehicle {c.vehicle + 1} ({c.role}) exited with {c.exit_code} after its vehicle was "
            f"lost to a fault at t = {lost[c.vehicle]:.1f} s (accepted)"
            for c in excused
        ]
        return {
            "ok": not bad,
            "value": len(bad),
            "message": "; ".join(notes) or "every companion exited with status 0",
        }

    def _finish(self) -> dict[str, Any]:
        sim = self.sim
        complete = self.stop_reason in ("duration", "done")
        wall_s = time.monotonic() - self.wall_start
        sim_s = sim.time_s if sim is not None else 0.0
        if self.manifest is not None:
            write_manifest(self.run_dir, self.manifest.finished(sim_s, complete))
        extra: dict[str, Any] = {
            "scenario": self.scenario.spec.name,
            "seed": self.seed,
            "complete": complete,
            "stop_reason": self.stop_reason,
            "mode": "lockstep" if self.options.speed is None else "paced",
            "speed_asked": self.options.speed,
            "sim_time_s": sim_s,
            "wall_time_s": wall_s,
            "real_time_factor": sim_s / wall_s if wall_s > 0 else None,
            "config_hash": self.scenario.config_hash(),
            "versions": versions(),
            "companions": {f"vehicle{c.vehicle + 1}": c.summary() for c in self.companions},
            "faults": (
                self.injector.records()
                if self.injector is not None
                else [f.record(None) for f in self.faults]
            ),
        }
        if self._gate is not None:
            extra["lockstep"] = self._gate.summary()
        if self.net_run is not None and sim is not None:
            extra["net"] = write_net_report(
                self.net_run, sim_s, self.run_dir / "net_report.json", {"seed": self.seed}
            )
        if sim is None or not (self.run_dir / "truth.csv").exists():
            report = extra | {"error": "the simulation did not start"}
            (self.run_dir / "report.json").write_text(json.dumps(report, indent=2) + "\n")
            return report
        log = FlightLog.load(self.run_dir)
        collisions = scenario_collisions(log, self.scenario)
        extra["checks"] = self._checks(log, collisions)
        extra["passed"] = complete and all(c["ok"] for c in extra["checks"].values())
        report = write_run_report(self.run_dir, self.scenario.world, None, extra)
        report.setdefault("fleet", {}).update(collisions.fleet_metrics())
        for v in log.vehicles:
            entry = report.get("vehicles", {}).get(v.name)
            if entry is not None:
                entry["collisions"] = {
                    "value": int(collisions.per_vehicle[v.index]),
                    "unit": "count",
                }
        if self.injector is not None:
            for i, kinds in self.injector.kinds_of().items():
                report.get("vehicles", {}).get(f"vehicle{i + 1}", {})["fault"] = kinds
        finish_report(report, self.scenario, self.role_envs)
        if self.scenario.spec.swarm_prediction:
            try:
                report["swarm_prediction"] = swarm_prediction(self.scenario, self.seed, report)
            except Exception as exc:  # the prediction must not cost the run's report
                report.setdefault("warnings", []).append(f"swarm_prediction: {exc!r}")
        (self.run_dir / "report.json").write_text(json.dumps(report, indent=2, default=str) + "\n")
        return report
