"""Shared machinery of the end-to-end tests: real ``swarmsitl up``, real clients, real UDP.

* :func:`running_swarm` starts ``python -m harness.cli up`` in a subprocess, waits for its
  endpoint table, and on exit stops it with SIGINT and checks exit code 0 and the tlogs.
* :func:`start_client` runs a script of ``tests/e2e/clients`` in its own process (own session,
  hard timeout); :meth:`ClientProcess.result` parses the JSON line it prints and makes sure no
  ``mavsdk_server`` of that client's gRPC port survives (MAVSDK_CONTRACT.md section 14).
* :class:`RawLink` is a raw pymavlink client on a plain UDP socket; :func:`download_items`
  reads a mission, geofence or rally list back with it (mission protocol, as PX4 serves it).
* :class:`MavProxy` runs MAVProxy as the ground station, driven line by line through its stdin.

Every wait is in simulated seconds, read from the run's clock file (``RUN/clock``, which
``swarmsitl up`` rewrites as the simulation advances, paced or lockstep):
:func:`wait_sim` (``harness.pytest_plugin.wait_until``) in this process; clients get
``SWARMSITL_CLOCK_FILE`` and wait with ``clients/_common.py``. A loaded machine runs the
simulation slower than :data:`SPEED`, never a test late; the wall clock only backs a wait up as
its watchdog (ten times the simulated limit at :data:`SPEED`, at least 120 s) besides
pytest-timeout's limit per test.

Each test module gets its own block of ports from :func:`module_ports`, drawn from the one port
allocator of the suite (:func:`harness.run.ports.free_port_block`: this xdist worker's slice of
20000-32767, never a block handed out before in this process), so modules never collide with
each other, with the other worker, nor with a developer's ``swarmsitl up`` on the default ports.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from harness.pytest_plugin import WaitTimeout, sim_time_s, wait_until
from harness.run.lockstep import ClockAcks, fleet_gate, run_gated
from harness.run.ports import free_port_block
from harness.run.sim_clock import ClockFile

E2E_DIR = Path(__file__).resolve().parent
CLIENTS_DIR = E2E_DIR / "clients"
REPO_ROOT = E2E_DIR.parents[1]

SPEED = 4.0
"""Most simulated seconds per wall second of every e2e run. The runs are in lockstep with their
clients (``swarmsitl up --lockstep --max-speed SPEED``, :func:`run_lockstep`): a stopped or
starved client holds the simulation. The cap keeps MAVSDK's and the emulator's wall-clock
timeouts (command retries, the mission protocol's 5 s) within a known number of simulated
seconds: at most SPEED x theirs."""

PORT_BLOCK = 10
"""Onboard-link ports per module: sdk ports at +0..+4, listen ports at +5..+9 (up to 5 vehicles)."""
MODULE_BLOCK = 20
"""All ports of a module: the onboard block, then 5 GCS-link listen ports and 5 gRPC ports."""

READY_MARKER = "Press Ctrl-C to stop."
STARTUP_TIMEOUT_S = 90.0
"""Wall seconds ``swarmsitl up`` gets to start (no simulation time passes before it is ready)."""
SHUTDOWN_TIMEOUT_S = 30.0
"""Wall seconds ``swarmsitl up`` gets to close its recordings after SIGINT."""
CLIENT_TIMEOUT_SIM_S = 960.0
"""Simulated seconds a client process may run by default."""


# --- waits -----------------------------------------------------------------------------------


def wait_sim(predicate, timeout_sim_s: float, clock: Path, what: str, poll_wall_s: float = 0.05):
    """``predicate()``'s first truthy value within ``timeout_sim_s`` simulated seconds of the
    run whose clock file is ``clock``; raises ``WaitTimeout`` (an AssertionError) after them.

    ``harness.pytest_plugin.wait_until`` at the e2e :data:`SPEED`: its only wall-clock limit is
    the watchdog (``WatchdogExpired``) for a simulation that stopped advancing.
    """
    return wait_until(predicate, timeout_sim_s, clock, what, speed=SPEED, poll_wall_s=poll_wall_s)


# --- ports -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Ports:
    """UDP and gRPC ports of one test module."""

    sdk: int
    """Vehicle i streams to sdk + i (MAVSDK: udpin://0.0.0.0:sdk+i)."""
    listen: int
    """Vehicle i's onboard link listens on listen + i."""
    gcs_listen: int
    """Vehicle i's ground-station link (only with a GCS port) listens on gcs_listen + i."""
    grpc: int
    """mavsdk_server gRPC port of client i is grpc + i."""

    def url(self, i: int = 0) -> str:
        return f"udpin://0.0.0.0:{self.sdk + i}"

    @property
    def gcs(self) -> int:
        """Ground-station port: the block's last sdk port (free while a module runs <5 vehicles)."""
        return self.sdk + PORT_BLOCK // 2 - 1


def module_ports() -> Ports:
    """A fresh block of ports for one test module (called once, at import, by each module).

    The block comes from :func:`harness.run.ports.free_port_block`, the suite's one allocator:
    free for UDP and TCP when chosen, inside this xdist worker's own slice, and never handed out
    again by this process, so a module imported early still owns its block when it runs.
    """
    base = free_port_block(MODULE_BLOCK)
    return Ports(
        sdk=base,
        listen=base + PORT_BLOCK // 2,
        gcs_listen=base + PORT_BLOCK,
        grpc=base + PORT_BLOCK + 5,
    )


def udp_port_free(port: int) -> bool:
    """True if nobody holds UDP ``port`` (checked on 0.0.0.0, which MAVSDK binds)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind(("0.0.0.0", port))
    except OSError:
        return False
    finally:
        sock.close()
    return True


def require_free_udp(ports: list[int]) -> None:
    busy = [p for p in ports if not udp_port_free(p)]
    if busy:
        pytest.fail(
            f"UDP port(s) {busy} already in use (another e2e run or a leftover mavsdk_server?); "
            "stop it (the ports are drawn afresh on the next run)"
        )


# --- mavsdk_server hygiene -------------------------------------------------------------------


def _cmdline(pid: int) -> list[str]:
    try:
        raw = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return []
    return [part.decode(errors="replace") for part in raw.split(b"\0") if part]


def _is_zombie_or_gone(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rsplit(")", 1)[-1].split()[0] in ("Z", "X")


def mavsdk_servers(grpc_port: int) -> list[int]:
    """Pids of live ``mavsdk_server`` processes serving gRPC on ``grpc_port``."""
    pids = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        pid = int(entry.name)
        args = _cmdline(pid)
        if not args or not any(Path(a).name.startswith("mavsdk_server") for a in args[:2]):
            continue
        port_args = [args[i + 1] for i, a in enumerate(args[:-1]) if a in ("-p", "--port")]
        if str(grpc_port) in port_args and not _is_zombie_or_gone(pid):
            pids.append(pid)
    return pids


def kill_mavsdk_servers(grpc_port: int) -> list[int]:
    """SIGKILL every ``mavsdk_server`` on ``grpc_port``; wait until gone; return their pids."""
    pids = mavsdk_servers(grpc_port)
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    deadline = time.monotonic() + 10.0
    while any(not _is_zombie_or_gone(pid) for pid in pids) and time.monotonic() < deadline:
        time.sleep(0.05)
    return pids


# --- clients ---------------------------------------------------------------------------------


@dataclass
class ClientResult:
    """What a client process printed and how it ended."""

    name: str
    returncode: int | None
    timed_out: bool
    data: dict
    stdout: str
    stderr: str
    leftover_servers: list[int] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.returncode == 0 and not self.timed_out and bool(self.data.get("ok"))

    def describe(self) -> str:
        """Failure message: stage reached, error, and the end of the client's stderr."""
        tail = "\n".join(self.stderr.strip().splitlines()[-25:])
        return (
            f"client {self.name}: rc={self.returncode} timed_out={self.timed_out} "
            f"stage={self.data.get('stage')} error={self.data.get('error')}\n"
            f"data={json.dumps(self.data, default=str)}\n--- stderr tail ---\n{tail}"
        )


class ClientProcess:
    """A client script running in its own process group, given the simulation's clock file
    (``SWARMSITL_CLOCK_FILE``) and ``timeout_sim_s`` simulated seconds to finish."""

    def __init__(
        self,
        script: str,
        args: list[str],
        log_dir: Path,
        clock: Path,
        timeout_sim_s: float,
        grpc_port: int | None = None,
    ) -> None:
        self.name = f"{script} {' '.join(args)}"
        self.grpc_port = grpc_port
        self.clock = clock
        self.timeout_sim_s = timeout_sim_s
        self.timeout_message = ""
        log_dir.mkdir(parents=True, exist_ok=True)
        stem = f"{Path(script).stem}-{grpc_port or os.getpid()}-{time.monotonic_ns()}"
        self._out_path = log_dir / f"{stem}.stdout"
        self._err_path = log_dir / f"{stem}.stderr"
        env = os.environ | {
            "SWARMSITL_SPEED": str(SPEED),
            "SWARMSITL_CLOCK_FILE": str(clock),
            "PYTHONUNBUFFERED": "1",
        }
        with self._out_path.open("w") as out, self._err_path.open("w") as err:
            self.proc = subprocess.Popen(
                [sys.executable, str(CLIENTS_DIR / script), *args],
                stdout=out,
                stderr=err,
                stdin=subprocess.DEVNULL,
                cwd=CLIENTS_DIR,
                env=env,
                start_new_session=True,
            )
        self.start_sim_s = sim_time_s(clock)

    def finished(self) -> bool:
        """The process has exited."""
        return self.proc.poll() is not None

    def sim_left_s(self) -> float:
        """Simulated seconds left of the client's limit."""
        return self.timeout_sim_s - (sim_time_s(self.clock) - self.start_sim_s)

    def result(self) -> ClientResult:
        """Wait until it exits (within its simulated limit; else it is killed and the result
        says ``timed_out``), kill the process group, parse the JSON line."""
        timed_out = False
        try:
            wait_sim(self.finished, max(0.0, self.sim_left_s()), self.clock, f"{self.name} exit")
        except WaitTimeout as exc:
            timed_out = True
            self.timeout_message = str(exc)
        finally:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait()
            leftovers = kill_mavsdk_servers(self.grpc_port) if self.grpc_port else []
        stdout = self._out_path.read_text(errors="replace")
        stderr = self._err_path.read_text(errors="replace")
        data: dict = {}
        for line in reversed(stdout.splitlines()):
            if line.startswith("{"):
                with contextlib.suppress(json.JSONDecodeError):
                    data = json.loads(line)
                    break
        if self.timeout_message:
            stderr += f"\n[e2e_support] {self.timeout_message}\n"
        result = ClientResult(
            self.name, self.proc.returncode, timed_out, data, stdout, stderr, leftovers
        )
        if self.grpc_port:
            assert not mavsdk_servers(self.grpc_port), (
                f"mavsdk_server on gRPC port {self.grpc_port} survived SIGKILL"
            )
        return result


def start_client(
    script: str,
    args: list[str],
    log_dir: Path,
    *,
    clock: Path,
    timeout_sim_s: float = CLIENT_TIMEOUT_SIM_S,
    grpc_port: int | None = None,
) -> ClientProcess:
    """Start ``tests/e2e/clients/<script>`` with ``sys.executable`` against the simulation
    whose clock file is ``clock`` (``Swarm.clock``)."""
    if grpc_port is not None:
        assert not mavsdk_servers(grpc_port), f"a mavsdk_server already serves {grpc_port}"
    return ClientProcess(script, args, log_dir, clock, timeout_sim_s, grpc_port)


def run_client(
    script: str,
    args: list[str],
    log_dir: Path,
    *,
    clock: Path,
    timeout_sim_s: float = CLIENT_TIMEOUT_SIM_S,
    grpc_port: int | None = None,
) -> ClientResult:
    """Run a client to completion (or to its simulated limit) and return its result."""
    return start_client(
        script, args, log_dir, clock=clock, timeout_sim_s=timeout_sim_s, grpc_port=grpc_port
    ).result()


# --- the vehicles ----------------------------------------------------------------------------


@contextlib.contextmanager
def lockstep_clock(path: Path) -> Iterator[tuple[ClockFile, ClockAcks]]:
    """The clock file of an in-process simulation and its acknowledgement folder, made before
    any client starts (``companion.clock`` takes part only if the folder exists when it is
    imported); closed on the way out."""
    clock = ClockFile(path)
    acks = ClockAcks(clock.path)
    try:
        yield clock, acks
    finally:
        acks.close()
        clock.close()


def run_lockstep(
    sim, clock: ClockFile, acks: ClockAcks, done: Callable[[], bool], max_duration_sim_s: float
) -> None:
    """Run an in-process ``harness.sim.simulation.Simulation`` (built with
    ``ping_period_s=LOCKSTEP.ping_period_s``) in lockstep with its clients, at most
    :data:`SPEED`, until ``done()`` or ``max_duration_sim_s``, publishing its time in ``clock``
    as ``swarmsitl up --lockstep --max-speed SPEED`` does (:func:`lockstep_clock`)."""

    def publish_and_check() -> bool:
        clock.publish(sim.time_s)
        return done()

    gate = fleet_gate(sim, acks, max_speed=SPEED)
    clock.publish(sim.time_s)
    run_gated(sim, gate, max_duration_sim_s, publish_and_check)
    clock.publish(sim.time_s)


def cli_command(subcommand: str, *options: object) -> list[str]:
    """``python -m harness.cli <subcommand> <options>`` with this interpreter."""
    return [sys.executable, "-m", "harness.cli", subcommand, *(str(o) for o in options)]


def cli_env() -> dict[str, str]:
    # A wide virtual terminal keeps rich from truncating the endpoint table's port numbers.
    return os.environ | {"PYTHONUNBUFFERED": "1", "COLUMNS": "200"}


@dataclass
class Swarm:
    """A running ``swarmsitl up``."""

    proc: subprocess.Popen
    vehicles: int
    ports: Ports
    out: Path
    log_path: Path

    def output(self) -> str:
        return self.log_path.read_text(errors="replace")

    @property
    def clock(self) -> Path:
        """The simulation's clock file (``SWARMSITL_CLOCK_FILE``)."""
        return self.out / "clock"

    def tlog(self, i: int = 0) -> Path:
        return self.out / f"vehicle{i + 1}.tlog"


def check_tlog(path: Path, sysid: int) -> int:
    """Assert ``path`` is a non-empty tlog pymavlink reads, with HEARTBEATs of ``sysid``."""
    assert path.is_file(), f"{path} missing"
    assert path.stat().st_size > 0, f"{path} is empty"
    log = mavutil.mavlink_connection(str(path))
    heartbeats = 0
    try:
        while True:
            msg = log.recv_match(type="HEARTBEAT")
            if msg is None:
                break
            if msg.get_srcSystem() == sysid and msg.get_srcComponent() == 1:
                heartbeats += 1
    finally:
        log.close()
    assert heartbeats > 0, f"no HEARTBEAT of system {sysid} in {path}"
    return heartbeats


def start_swarm(
    vehicles: int, ports: Ports, out: Path, extra: tuple = (), gcs_port: int = 0
) -> Swarm:
    """Start ``swarmsitl up`` and return once it printed its endpoint table.

    ``gcs_port`` is passed as ``--gcs-port``: 0 (no ground-station link) unless a test runs
    a ground station there; the GCS links then listen on the module's ``gcs_listen`` ports.
    """
    out.mkdir(parents=True, exist_ok=True)
    log_path = out.parent / f"{out.name}-swarmsitl.log"
    cmd = cli_command(
        "up",
        "--vehicles", vehicles,
        "--lockstep", "--max-speed", SPEED,
        "--sdk-port", ports.sdk,
        "--listen-port", ports.listen,
        "--gcs-port", gcs_port,
        "--gcs-listen-port", ports.gcs_listen,
        "--out", out,
        "--no-camera",  # no rendering, no TCP 5600+i; a test that wants them passes --camera
        *extra,
    )  # fmt: skip
    with log_path.open("w") as log:
        proc = subprocess.Popen(
            cmd,
            stdout=log,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            cwd=REPO_ROOT,
            env=cli_env(),
            start_new_session=True,
        )
    swarm = Swarm(proc, vehicles, ports, out, log_path)
    deadline = time.monotonic() + STARTUP_TIMEOUT_S
    while READY_MARKER not in swarm.output():
        if proc.poll() is not None:
            pytest.fail(f"swarmsitl up exited with {proc.returncode}:\n{swarm.output()}")
        if time.monotonic() > deadline:
            proc.kill()
            proc.wait()
            pytest.fail(f"swarmsitl up not ready after {STARTUP_TIMEOUT_S} s:\n{swarm.output()}")
        time.sleep(0.1)
    table = swarm.output()
    for i in range(vehicles):
        assert f"127.0.0.1:{ports.listen + i}" in table, table
        assert f"udpin://0.0.0.0:{ports.sdk + i}" in table, table
    if gcs_port:
        assert f"127.0.0.1:{gcs_port}" in table, table
        for i in range(vehicles):
            assert f"127.0.0.1:{ports.gcs_listen + i}" in table, table
    return swarm


def stop_swarm(swarm: Swarm) -> None:
    """SIGINT, wait, assert exit code 0 and one readable tlog with HEARTBEATs per vehicle."""
    proc = swarm.proc
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=SHUTDOWN_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            pytest.fail(f"swarmsitl up ignored SIGINT for {SHUTDOWN_TIMEOUT_S} s")
    assert proc.returncode == 0, f"swarmsitl up exit code {proc.returncode}:\n{swarm.output()}"
    assert "stopped at t =" in swarm.output(), swarm.output()
    for i in range(swarm.vehicles):
        check_tlog(swarm.tlog(i), sysid=i + 1)


@contextlib.contextmanager
def running_swarm(vehicles: int, ports: Ports, out: Path, gcs_port: int = 0) -> Iterator[Swarm]:
    """``swarmsitl up`` for the duration of the block, checked on the way out."""
    require_free_udp(
        [ports.listen + i for i in range(vehicles)]
        + [ports.sdk + i for i in range(vehicles)]
        + ([gcs_port, *(ports.gcs_listen + i for i in range(vehicles))] if gcs_port else [])
    )
    swarm = start_swarm(vehicles, ports, out, gcs_port=gcs_port)
    try:
        yield swarm
    finally:
        stop_swarm(swarm)


# --- raw pymavlink client --------------------------------------------------------------------


class RawLink:
    """A MAVLink 2 client on its own UDP socket, as MAVSDK would be (sysid 245, compid 190).

    ``inbox`` keeps every decoded message received; :meth:`wait_for` and :meth:`pump` add to it.
    Their durations are simulated seconds of the run whose clock file is ``clock``.
    """

    def __init__(self, vehicle_port: int, clock: Path, sysid: int = 245, compid: int = 190) -> None:
        self.clock = clock
        self.addr = ("127.0.0.1", vehicle_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        self.mav.robust_parsing = True
        self.inbox: list = []

    def close(self) -> None:
        self.sock.close()

    def pack(self, msg) -> bytes:
        frame = bytes(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) & 0xFF
        return frame

    def send_raw(self, data: bytes) -> None:
        self.sock.sendto(data, self.addr)

    def send(self, msg) -> bytes:
        frame = self.pack(msg)
        self.send_raw(frame)
        return frame

    def _receive_once(self) -> list:
        try:
            data, _ = self.sock.recvfrom(65535)
        except TimeoutError:
            return []
        msgs = [
            m
            for m in (self.mav.parse_buffer(data) or [])
            if m.get_type() not in ("BAD_DATA", "UNKNOWN")
        ]
        self.inbox.extend(msgs)
        return msgs

    def pump(self, seconds: float) -> list:
        """Receive for ``seconds`` of simulated time; return what arrived."""
        got: list = []
        end = sim_time_s(self.clock) + seconds

        def received_until_end() -> bool:
            got.extend(self._receive_once())
            return sim_time_s(self.clock) >= end

        wait_sim(received_until_end, seconds + 1.0, self.clock, "the end", poll_wall_s=0)
        return got

    def wait_for(self, predicate: Callable, timeout_s: float = 10.0):
        """First newly received message with ``predicate(msg)``; None after ``timeout_s``
        simulated seconds."""

        def matching():
            return next((m for m in self._receive_once() if predicate(m)), None)

        try:
            return wait_sim(matching, timeout_s, self.clock, "matching message", poll_wall_s=0)
        except WaitTimeout:
            return None

    def drain(self) -> None:
        """Drop whatever is queued in the socket and the inbox."""
        self.sock.setblocking(False)
        try:
            while True:
                self.sock.recvfrom(65535)
        except BlockingIOError:
            pass
        finally:
            self.sock.settimeout(0.05)
        self.inbox.clear()

    def heartbeats(self, count: int, timeout_s: float = 30.0) -> list:
        """The next ``count`` HEARTBEATs from the autopilot (sysid 1 / compid 1)."""
        beats = []
        for _ in range(count):
            hb = self.wait_for(
                lambda m: m.get_type() == "HEARTBEAT" and from_autopilot(m), timeout_s
            )
            assert hb is not None, f"no HEARTBEAT within {timeout_s} simulated s"
            beats.append(hb)
        return beats


def from_autopilot(msg, sysid: int = 1) -> bool:
    """Sent by the autopilot itself (other clients' frames are forwarded between links too)."""
    return msg.get_srcSystem() == sysid and msg.get_srcComponent() == 1


def command_long(
    command: int,
    params: tuple = (),
    target_system: int = 1,
    target_component: int = 1,
):
    """COMMAND_LONG with params 1..7 (missing ones NaN, as MAVSDK sends them)."""
    p = list(params) + [math.nan] * (7 - len(params))
    return mavlink2.MAVLink_command_long_message(target_system, target_component, command, 0, *p)


def download_items(lk: RawLink, mission_type: int, timeout_s: float = 5.0) -> list:
    # timeout_s: simulated seconds per request
    """Read the vehicle's mission, geofence or rally list (MISSION_ITEM_INTs) as a GCS would.

    MISSION_REQUEST_LIST -> MISSION_COUNT, then one MISSION_REQUEST_INT per item, each re-sent
    up to three times, then MISSION_ACK ACCEPTED (MAVSDK_CONTRACT.md section 7, download).
    Fails the test, naming the step, when the vehicle does not answer.
    """

    def ask(request, predicate, what: str):
        for _ in range(3):
            lk.send(request)
            reply = lk.wait_for(predicate, timeout_s)
            if reply is not None:
                return reply
        pytest.fail(
            f"mission download (type {mission_type}): no {what} within 3 x {timeout_s} simulated s"
        )

    def ours(m, name: str) -> bool:
        return (
            m.get_type() == name
            and m.mission_type == mission_type
            and (m.target_system, m.target_component) == (lk.mav.srcSystem, lk.mav.srcComponent)
        )

    count = ask(
        mavlink2.MAVLink_mission_request_list_message(1, 1, mission_type),
        lambda m: ours(m, "MISSION_COUNT"),
        "MISSION_COUNT",
    ).count
    items = []
    for seq in range(count):
        items.append(
            ask(
                mavlink2.MAVLink_mission_request_int_message(1, 1, seq, mission_type),
                lambda m, seq=seq: ours(m, "MISSION_ITEM_INT") and m.seq == seq,
                f"MISSION_ITEM_INT {seq} of {count}",
            )
        )
    lk.send(mavlink2.MAVLink_mission_ack_message(1, 1, mavlink2.MAV_MISSION_ACCEPTED, mission_type))
    return items


# --- MAVProxy ----------------------------------------------------------------------------------


MAVPROXY_MODULES = "wp,fence,rally,param,arm,mode,cmdlong"
"""MAVProxy modules loaded instead of its defaults: no console, map, GUI, ftp or terrain."""


class MavProxy:
    """MAVProxy as the ground station, in its own process group, driven through its stdin.

    Commands are written to MAVProxy's prompt one line at a time (its interactive shell reads
    plain ``input()`` lines from a pipe); its output goes to ``<log_dir>/mavproxy.out``, which
    :meth:`wait_for` polls for acknowledgements, in simulated seconds of the run whose clock file
    is ``clock``. ``HOME`` is ``log_dir``, so no personal ``~/.mavinit.scr`` runs; logs and the
    tlog stay in ``log_dir``. :meth:`close` always kills the process group.
    """

    def __init__(self, gcs_port: int, log_dir: Path, clock: Path) -> None:
        script = Path(sys.executable).with_name("mavproxy.py")
        if not script.is_file():
            pytest.fail(f"{script} not found: install the test extras (MAVProxy)")
        log_dir.mkdir(parents=True, exist_ok=True)
        self.out_path = log_dir / "mavproxy.out"
        self.clock = clock
        cmd = [
            sys.executable, str(script),
            f"--master=udpin:127.0.0.1:{gcs_port}",
            "--target-system=1", "--target-component=1",
            f"--default-modules={MAVPROXY_MODULES}",
            f"--state-basedir={log_dir}",
            f"--logfile={log_dir / 'mavproxy.tlog'}",
        ]  # fmt: skip
        env = os.environ | {"PYTHONUNBUFFERED": "1", "HOME": str(log_dir), "TERM": "dumb"}
        with self.out_path.open("w") as out:
            self.proc = subprocess.Popen(
                cmd,
                stdin=subprocess.PIPE,
                stdout=out,
                stderr=subprocess.STDOUT,
                cwd=log_dir,
                env=env,
                text=True,
                start_new_session=True,
            )

    def output(self, since: int = 0) -> str:
        """MAVProxy's output from character ``since`` on."""
        return self.out_path.read_text(errors="replace")[since:]

    def mark(self) -> int:
        """A position in the output: pass it as ``since`` to look only at what follows."""
        return len(self.output())

    def tail(self, lines: int = 40) -> str:
        return "\n".join(self.output().splitlines()[-lines:])

    def fail(self, why: str) -> None:
        pytest.fail(f"MAVProxy: {why}\n--- MAVProxy output (tail) ---\n{self.tail()}")

    def send(self, line: str) -> int:
        """Type ``line`` at MAVProxy's prompt; return the output mark from just before."""
        if self.proc.poll() is not None:
            self.fail(f"exited with {self.proc.returncode} before {line!r}")
        mark = self.mark()
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return mark

    def wait_for(self, pattern: str, since: int = 0, timeout_s: float = 20.0) -> re.Match:
        """First match of regex ``pattern`` in the output after ``since`` within ``timeout_s``
        simulated seconds; fail after them."""

        def found() -> re.Match | None:
            match = re.search(pattern, self.output(since))
            if match is None and self.proc.poll() is not None:
                self.fail(f"exited with {self.proc.returncode} while waiting for {pattern!r}")
            return match

        try:
            return wait_sim(found, timeout_s, self.clock, repr(pattern))
        except WaitTimeout:
            self.fail(f"no {pattern!r} within {timeout_s} simulated s")
            raise

    def close(self) -> None:
        """EOF on stdin (MAVProxy's way to quit), then SIGKILL the whole process group."""
        with contextlib.suppress(OSError):
            self.proc.stdin.close()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=5.0)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait()
