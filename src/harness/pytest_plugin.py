"""pytest plugin: fly a fleet or a whole scenario in a test, then assert on what happened.

Installed with swarmsitl (entry point ``pytest11``), so any test suite gets the fixtures:

* ``swarmsitl_run``: a function that runs a scenario file (``swarmsitl run``, in its own
  process, lockstep by default) and returns a :class:`RunResult` with the report, the flight log
  and assertion helpers;
* ``swarmsitl_fleet``: a function that starts ``swarmsitl up`` (vehicles on a world, paced or
  lockstep) and returns a :class:`Fleet` with each vehicle's connection URL; the test runs its own
  companion code against them, then ``fleet.stop()`` returns the flight log;
* ``swarmsitl_ports``: free port bases for this test (two tests may run at once: under
  pytest-xdist each worker draws from its own slice of ports).

Waits and windows are in simulation time; nothing here asserts wall-clock timings.
:func:`sim_time_s` reads a run's simulation clock (``RUN/clock``, which ``swarmsitl up`` and
``swarmsitl run`` publish paced and lockstep alike) and :func:`wait_until` waits on it:
``fleet.wait_until(predicate, timeout_sim_s=30)``. The only wall-clock limit of such a wait is
its watchdog (:func:`watchdog_wall_s`), far beyond the simulated limit, for a simulation that
stopped advancing. The module
imports nothing heavy at start-up (pytest loads it in every session): the simulator's packages
are imported when a fixture is used.
``docs/testing_your_companion.md`` has the example test a user writes.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from harness.run.ports import RunPorts, free_ports
from harness.run.sim_clock import read_time_s

if TYPE_CHECKING:
    from harness.report.flight_log import FlightLog

RUN_TIMEOUT_WALL_S = 900.0
"""Default wall-clock limit of one ``swarmsitl run`` in a test (a hung run fails, never hangs)."""
FLEET_READY_TIMEOUT_S = 60.0
"""Wall seconds ``swarmsitl up`` gets to print its endpoint table."""
READY_MARKER = "Press Ctrl-C to stop."
CLOCK_FILE = "clock"
"""The run directory's simulation clock: one little-endian float64, simulated seconds."""
WATCHDOG_MIN_WALL_S = 120.0
"""The shortest watchdog of a wait in simulated time, wall seconds."""
WATCHDOG_FACTOR = 10.0
"""A wait's watchdog is this many times its simulated limit at the nominal speed."""
POLL_WALL_S = 0.05
"""How often :func:`wait_until` asks its predicate, wall seconds."""


def sim_time_s(clock: Path) -> float:
    """The simulation time published in ``clock`` (a run directory or its clock file), s.

    ``swarmsitl up`` and ``swarmsitl run`` rewrite ``RUN/clock`` as the simulation advances,
    paced or lockstep; before the simulation starts it holds 0.
    """
    return read_time_s(clock / CLOCK_FILE if clock.is_dir() else clock)


def watchdog_wall_s(timeout_sim_s: float, speed: float | None = None) -> float:
    """The wall-clock watchdog of a wait of ``timeout_sim_s`` simulated seconds.

    ``WATCHDOG_FACTOR`` times the limit at the nominal ``speed`` (None, lockstep: 1), at least
    ``WATCHDOG_MIN_WALL_S``: it fires only when the simulation stopped or all but stopped, never
    because a loaded machine ran it slower than its nominal speed.
    """
    nominal = speed if speed and speed > 0 else 1.0
    return max(WATCHDOG_MIN_WALL_S, WATCHDOG_FACTOR * timeout_sim_s / nominal)


class WaitTimeout(AssertionError):
    """A wait's simulated time limit passed: the assertion failed."""


class WatchdogExpired(AssertionError):
    """A wait's wall-clock watchdog fired: the simulation stopped advancing (or all but)."""


def wait_until(
    predicate: Callable[[], Any],
    timeout_sim_s: float,
    clock: Path,
    what: str = "the condition",
    *,
    speed: float | None = None,
    poll_wall_s: float = POLL_WALL_S,
) -> Any:
    """Call ``predicate()`` until it returns something truthy, and return that.

    Raises :class:`WaitTimeout` when ``timeout_sim_s`` seconds of the simulation behind
    ``clock`` (see :func:`sim_time_s`) passed first. The wall clock only decides through the
    watchdog (:func:`watchdog_wall_s` of ``speed``, the simulation's nominal speed), which raises
    :class:`WatchdogExpired`, saying that it is one. ``poll_wall_s`` is the pause between calls
    (0 for a predicate that blocks briefly itself, e.g. on a socket with a timeout).
    """
    start_sim = sim_time_s(clock)
    start_wall = time.monotonic()
    watchdog = watchdog_wall_s(timeout_sim_s, speed)
    while True:
        # The clock is read before the predicate: a simulation that runs far ahead while this
        # process is slow cannot turn an event it saw in time into a timeout.
        elapsed = sim_time_s(clock) - start_sim
        found = predicate()
        if found:
            return found
        if elapsed >= timeout_sim_s:
            raise WaitTimeout(f"no {what} within {timeout_sim_s:g} simulated s")
        waited = time.monotonic() - start_wall
        if waited > watchdog:
            raise WatchdogExpired(
                f"watchdog, not a timing assertion: no {what} after {waited:.0f} wall s, in "
                f"which the simulation advanced only {elapsed:.1f} of the {timeout_sim_s:g} "
                f"simulated s allowed (stopped, or starved of CPU?)"
            )
        if poll_wall_s > 0:
            time.sleep(poll_wall_s)


def _cli(*args: object) -> list[str]:
    return [sys.executable, "-m", "harness.cli", *(str(a) for a in args)]


def _port_options(ports: RunPorts) -> list[object]:
    return ["--sdk-port", ports.sdk, "--listen-port", ports.listen, "--payload-port", ports.payload]


def _checks() -> Any:
    from harness.report import flight_checks

    return flight_checks


def _load_log(run_dir: Path) -> FlightLog:
    from harness.report.flight_log import FlightLog

    return FlightLog.load(run_dir)


class _Checks:
    """Assertion helpers over a flight log (shared by RunResult and a stopped Fleet)."""

    log: FlightLog
    """The run's flight log (each subclass loads it its way)."""

    def assert_waypoints_reached(
        self,
        vehicle: int,
        waypoints_enu_m: Sequence[Sequence[float]],
        tolerance_m: float,
        in_order: bool = True,
    ) -> None:
        """Vehicle ``vehicle`` (0-based) passed within ``tolerance_m`` of every waypoint (ENU)."""
        _checks().assert_waypoints_reached(
            self.log, vehicle, waypoints_enu_m, tolerance_m, in_order
        )

    def assert_min_separation(self, distance_m: float) -> None:
        """No two vehicles came closer than ``distance_m``."""
        _checks().assert_min_separation(self.log, distance_m)

    def assert_max_tilt(self, max_deg: float, vehicle: int | None = None) -> None:
        """No vehicle (or ``vehicle``) tilted more than ``max_deg``."""
        _checks().assert_max_tilt(self.log, max_deg, vehicle)

    def assert_landed_and_disarmed(self, vehicle: int | None = None) -> None:
        """Every vehicle (or ``vehicle``) ended on the ground, disarmed."""
        _checks().assert_landed_and_disarmed(self.log, vehicle)

    def assert_no_failsafe(self) -> None:
        """No vehicle announced a failsafe."""
        _checks().assert_no_failsafe(self.log)


@dataclass
class RunResult(_Checks):
    """A finished ``swarmsitl run``: exit status, report, flight log, assertion helpers."""

    run_dir: Path
    exit_code: int
    output: str
    _log: FlightLog | None = field(default=None, repr=False)

    @property
    def report(self) -> dict[str, Any]:
        """``report.json``."""
        path = self.run_dir / "report.json"
        if not path.exists():
            raise AssertionError(f"the run wrote no report; its output:\n{self.output}")
        return json.loads(path.read_text())

    @property
    def log(self) -> FlightLog:
        """Truth and tlogs of the run."""
        if self._log is None:
            self._log = _load_log(self.run_dir)
        return self._log

    def metric(self, name: str) -> Any:
        """A report value by dotted name, e.g. ``vehicles.vehicle1.max_tilt_deg``."""
        from harness.report.totals import lookup

        return lookup(self.report, name)

    def assert_passed(self) -> None:
        """The run completed and every check of the scenario passed (else the failures)."""
        report = self.report
        if report.get("passed"):
            return
        lines = [f"run in {self.run_dir} did not pass (exit {self.exit_code}):"]
        if not report.get("complete"):
            lines.append(f"  incomplete: {report.get('stop_reason')}")
        for name, check in report.get("checks", {}).items():
            if not check["ok"]:
                lines.append(f"  {name}: {check['message']}")
        for key, c in report.get("companions", {}).items():
            if c.get("traceback"):
                lines.append(f"  {key}'s companion exited {c['exit_code']}:\n{c['traceback']}")
        raise AssertionError("\n".join(lines))

    def assert_companions_succeeded(self) -> None:
        """Every companion process exited with status 0."""
        bad = {k: c for k, c in self.report.get("companions", {}).items() if c["exit_code"] != 0}
        if bad:
            raise AssertionError(
                "\n".join(
                    f"{k} ({c['role']}) exited {c['exit_code']}:\n{c.get('traceback') or ''}"
                    for k, c in bad.items()
                )
            )


@dataclass
class Fleet(_Checks):
    """A running ``swarmsitl up``: where to connect; ``stop()`` ends it and loads the log."""

    process: subprocess.Popen
    vehicles: int
    ports: RunPorts
    run_dir: Path
    output_path: Path
    lockstep: bool
    speed: float | None = None
    """Simulated seconds per wall second asked for (None: lockstep)."""
    _log: FlightLog | None = field(default=None, repr=False)

    def url(self, i: int = 0) -> str:
        """MAVSDK URL of vehicle ``i`` (0-based): ``udpin://0.0.0.0:PORT``."""
        return f"udpin://0.0.0.0:{self.ports.sdk + i}"

    @property
    def urls(self) -> list[str]:
        """MAVSDK URL of every vehicle."""
        return [self.url(i) for i in range(self.vehicles)]

    def pymavlink_url(self, i: int = 0) -> str:
        """Pymavlink URL of vehicle ``i``: ``udpin:0.0.0.0:PORT``."""
        return f"udpin:0.0.0.0:{self.ports.sdk + i}"

    def grpc_port(self, i: int = 0) -> int:
        """A free port for vehicle ``i``'s client's mavsdk_server."""
        return self.ports.grpc + i

    @property
    def clock(self) -> Path:
        """The simulation clock file (``SWARMSITL_CLOCK_FILE``, paced and lockstep)."""
        return self.run_dir / CLOCK_FILE

    @property
    def env(self) -> dict[str, str]:
        """Environment for companion processes: ``SWARMSITL_CLOCK_FILE`` added.

        ``companion.clock`` then reads and waits in the simulation's time, paced or lockstep.
        """
        return os.environ | {"SWARMSITL_CLOCK_FILE": str(self.clock)}

    def sim_time_s(self) -> float:
        """The fleet's simulation time now, s."""
        return sim_time_s(self.clock)

    def wait_until(
        self, predicate: Callable[[], Any], timeout_sim_s: float, what: str = "the condition"
    ) -> Any:
        """``predicate()``'s first truthy value within ``timeout_sim_s`` simulated seconds.

        :func:`wait_until` on the fleet's clock (the wall clock only as its watchdog); fails at
        once, with its output, if ``swarmsitl up`` exited.
        """

        def poll() -> Any:
            if self.process.poll() is not None:
                raise AssertionError(
                    f"swarmsitl up exited {self.process.returncode} while waiting for {what}:\n"
                    f"{self.output}"
                )
            return predicate()

        return wait_until(poll, timeout_sim_s, self.clock, what, speed=self.speed)

    @property
    def output(self) -> str:
        """What ``swarmsitl up`` printed so far."""
        return self.output_path.read_text(errors="replace")

    def stop(self, timeout_s: float = 60.0) -> FlightLog:
        """Stop the fleet (SIGINT, as Ctrl-C), wait for its recordings, return the flight log."""
        self.terminate(timeout_s)
        if self._log is None:
            self._log = _load_log(self.run_dir)
        return self._log

    def terminate(self, timeout_s: float = 60.0) -> None:
        """Stop the fleet (SIGINT, as Ctrl-C) and wait until its recordings are closed."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
            try:
                self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
                raise AssertionError(f"swarmsitl up ignored SIGINT:\n{self.output}") from None

    @property
    def log(self) -> FlightLog:
        """The flight log (stops the fleet first)."""
        return self.stop()


@pytest.fixture
def swarmsitl_ports() -> RunPorts:
    """Free port bases for this test, from this xdist worker's own slice of ports.

    Two tests on two workers never get the same ports (:func:`harness.run.ports.free_ports`).
    """
    return free_ports()


def _beside(test_file: Path, path: str | Path) -> Path:
    """``path`` as the calling test means it: a relative path starts at the test file's folder.

    So ``swarmsitl_run("hop.yaml")`` finds the scenario next to the test whether pytest runs
    from the project root, the test's folder or anywhere else.
    """
    return (test_file.parent / path).absolute()


def _world_arg(test_file: Path, world: str | Path) -> str | Path:
    """A ``--world`` value: ``example:KIND`` as it is, a file path beside the test file."""
    if isinstance(world, str) and world.startswith("example:"):
        return world
    return _beside(test_file, world)


@pytest.fixture
def swarmsitl_run(
    request: pytest.FixtureRequest, tmp_path: Path, swarmsitl_ports: RunPorts
) -> Callable[..., RunResult]:
    """Run a scenario: ``swarmsitl_run("my.yaml", seed=1)`` -> :class:`RunResult`.

    A relative scenario path starts at the calling test file's folder; a relative ``out`` at
    the current directory.
    Keyword arguments: ``seed``, ``speed`` (None: lockstep), ``out`` (default: a directory
    under the test's tmp_path), ``timeout_wall_s`` (the run is stopped and reported incomplete
    after it), ``extra_args`` (more ``swarmsitl run`` options).
    """
    count = [0]

    def run(
        scenario: str | Path,
        *,
        seed: int | None = None,
        speed: float | None = None,
        out: Path | None = None,
        timeout_wall_s: float = RUN_TIMEOUT_WALL_S,
        extra_args: Sequence[object] = (),
    ) -> RunResult:
        count[0] += 1
        run_dir = (out or tmp_path / f"run{count[0]}").absolute()
        ports = swarmsitl_ports
        scenario = _beside(request.path, scenario)
        args: list[object] = ["run", scenario, "--out", run_dir, *_port_options(ports)]
        args += ["--grpc-port", ports.grpc, "--net-port", ports.net, "--mocap-port", ports.mocap]
        args += ["--net-proxy-port", ports.net_proxy, "--timeout", timeout_wall_s]
        args += [] if seed is None else ["--seed", seed]
        args += ["--lockstep"] if speed is None else ["--speed", speed]
        proc = subprocess.run(
            _cli(*args, *extra_args),
            capture_output=True,
            text=True,
            env=os.environ | {"COLUMNS": "200", "PYTHONUNBUFFERED": "1"},
            timeout=timeout_wall_s + 120,
            check=False,
        )
        return RunResult(run_dir, proc.returncode, proc.stdout + proc.stderr)

    return run


@pytest.fixture
def swarmsitl_fleet(
    request: pytest.FixtureRequest, tmp_path: Path, swarmsitl_ports: RunPorts
) -> Iterator[Callable[..., Fleet]]:
    """Start vehicles with ``swarmsitl up``; returns the start function.

    ``fleet = swarmsitl_fleet(vehicles=2, world="example:offshore")``. Keyword arguments:
    ``vehicles``, ``world`` (a world file, ``example:KIND`` or None),
    ``launch_area``, ``speed`` (paced, simulated s per wall s) or ``lockstep=True`` (as fast as
    possible; companions use ``fleet.env`` for the simulation clock; ``extra_args=["--max-speed",
    4]`` caps it, as the project's own end-to-end tests do), ``frame``, ``extra_args``.
    Every fleet still running at the end of the test is stopped.
    """
    fleets: list[Fleet] = []

    def start(
        *,
        vehicles: int = 1,
        world: str | Path | None = None,
        launch_area: str | None = None,
        speed: float = 1.0,
        lockstep: bool = False,
        frame: str | None = None,
        extra_args: Sequence[object] = (),
    ) -> Fleet:
        ports = swarmsitl_ports
        run_dir = tmp_path / f"fleet{len(fleets) + 1}"
        args: list[object] = ["up", "-n", vehicles, "--out", run_dir, "--gcs-port", 0]
        args += [*_port_options(ports), "--video-port", 0, "--payload-listen-port", 0]
        args += ["--lockstep"] if lockstep else ["--speed", speed]
        if world is not None:
            args += ["--world", _world_arg(request.path, world)]
        if launch_area is not None:
            args += ["--launch-area", launch_area]
        if frame is not None:
            args += ["--frame", frame]
        run_dir.mkdir(parents=True, exist_ok=True)
        output_path = tmp_path / f"fleet{len(fleets) + 1}.log"
        with output_path.open("w") as out:
            proc = subprocess.Popen(
                _cli(*args, *extra_args),
                stdout=out,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=os.environ | {"COLUMNS": "200", "PYTHONUNBUFFERED": "1"},
                start_new_session=True,
            )
        fleet = Fleet(
            proc, vehicles, ports, run_dir, output_path, lockstep, None if lockstep else speed
        )
        fleets.append(fleet)
        deadline = time.monotonic() + FLEET_READY_TIMEOUT_S
        while READY_MARKER not in fleet.output:
            if proc.poll() is not None:
                raise AssertionError(f"swarmsitl up exited {proc.returncode}:\n{fleet.output}")
            if time.monotonic() > deadline:
                proc.kill()
                proc.wait()
                raise AssertionError(f"swarmsitl up not ready:\n{fleet.output}")
            time.sleep(0.1)
        return fleet

    yield start
    for fleet in fleets:
        with contextlib.suppress(AssertionError):
            fleet.terminate()


def pytest_configure(config: pytest.Config) -> None:
    """Register the plugin's marker."""
    config.addinivalue_line(
        "markers", "swarmsitl: a test that flies swarmsitl vehicles (plugin fixtures)"
    )
