"""The lifecycle of one run, written once: simulation, clock file, processes, signals, pacing.

``swarmsitl up``, ``first-flight``, ``net-demo`` and ``run`` (a scenario, and through it the
``full`` trials of a sweep) each start a simulation, publish its clock to the processes they
start, run it paced or in lockstep, and on the way out stop those processes and close
everything in an order that keeps the recordings whole. :class:`RunSession` owns that:

    with RunSession(sim, run_dir, speed=2.0) as session:
        session.start_process("client", cmd, log_path=run_dir / "client.log")
        session.advance(math.inf, lambda: session.stopped or client_ended())

On leaving the ``with`` block the processes are stopped (SIGTERM, then SIGKILL after a grace
period), the simulation is closed (tlogs, ``truth.csv``), then the clock file and the lockstep
acknowledgements; the signal handlers are restored last, so that a second Ctrl-C during the
shutdown only sets the flag again and cannot cut the recordings short.
"""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType, TracebackType

from harness.net.roles import stop_processes
from harness.run.lockstep import ClockAcks, fleet_gate, run_gated
from harness.run.sim_clock import ClockFile
from harness.sim.simulation import Simulation

STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class RunSession:
    """One run's simulation and everything around it, opened and closed as one.

    Args:
        sim: the opened simulation; the session closes it.
        run_dir: where the clock file (``clock``) is written.
        speed: simulated seconds per wall second of a paced run; None: lockstep.
        max_speed: with lockstep, never faster than this (0: no cap).
        handle_signals: SIGINT and SIGTERM set :attr:`stopped` instead of raising (a command
            line run); False leaves the handlers alone (a caller that has its own).
    """

    def __init__(
        self,
        sim: Simulation,
        run_dir: Path,
        *,
        speed: float | None = 1.0,
        max_speed: float = 0.0,
        handle_signals: bool = True,
    ) -> None:
        if speed is not None and not speed > 0:
            raise ValueError(f"speed must be > 0 or None (lockstep), got {speed}")
        self.sim = sim
        self.run_dir = run_dir
        self.speed = speed
        self.max_speed = max_speed
        self.stopped = False
        """Set by SIGINT / SIGTERM: the run should end."""
        self.processes: dict[str, subprocess.Popen] = {}
        """What :meth:`start_process` started or :meth:`adopt_process` took, by name; stopped
        when the session ends."""
        self._handle_signals = handle_signals
        self._old_handlers: dict[int, object] = {}
        self._stack = contextlib.ExitStack()
        """Closed last opened first: processes, simulation, clock file, acknowledgements."""
        try:
            self.clock = ClockFile(run_dir / "clock")
            self._stack.callback(self.clock.close)
            # Before any process can start: companion.clock takes part only if the folder exists.
            self.acks = ClockAcks(self.clock.path) if speed is None else None
            if self.acks is not None:
                self._stack.callback(self.acks.close)
        except BaseException:
            self._stack.close()
            sim.close()
            raise
        self._stack.callback(sim.close)
        self._stack.callback(self._stop_processes)
        self.wall_start_s = time.monotonic()
        """``time.monotonic()`` when the session opened (``SWARMSITL_CLOCK_ORIGIN``)."""
        self.sim_start_s = sim.time_s

    @property
    def lockstep(self) -> bool:
        """True when the simulation waits for its participants instead of the wall clock."""
        return self.speed is None

    def __enter__(self) -> RunSession:
        if self._handle_signals:
            self._old_handlers = {s: signal.signal(s, self._on_signal) for s in STOP_SIGNALS}
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Stop the processes, close the simulation, the clock and the acknowledgements.

        The signal handlers come back last: until then a signal only sets :attr:`stopped`.
        """
        try:
            self._stack.close()
        finally:
            old, self._old_handlers = self._old_handlers, {}
            for s, handler in old.items():
                signal.signal(s, handler)

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self.stopped = True

    def environment(self) -> dict[str, str]:
        """What a process of this run is told of the clock (``companion.clock`` reads it)."""
        return {
            "SWARMSITL_SPEED": f"{self.speed if self.speed is not None else 1.0:g}",
            "SWARMSITL_CLOCK_ORIGIN": repr(self.wall_start_s),
            "SWARMSITL_CLOCK_FILE": str(self.clock.path),
        }

    def start_process(
        self,
        name: str,
        cmd: Sequence[str],
        log_path: Path,
        env: dict[str, str] | None = None,
    ) -> subprocess.Popen:
        """Start ``cmd`` with the run's clock environment, its output in ``log_path``.

        The process is stopped when the session ends (if it still runs).
        """
        self._check_name(name)
        full_env = os.environ | self.environment() | (env or {})
        with log_path.open("w") as log:
            proc = subprocess.Popen(
                list(cmd), env=full_env, stdout=log, stderr=subprocess.STDOUT, text=True
            )
        self.adopt_process(name, proc)
        return proc

    def adopt_process(self, name: str, proc: subprocess.Popen) -> None:
        """Stop ``proc`` with the session's own processes (started elsewhere)."""
        self._check_name(name)
        self.processes[name] = proc

    def _check_name(self, name: str) -> None:
        if name in self.processes:
            raise ValueError(f"a process named {name!r} already runs in this session")

    def _stop_processes(self) -> None:
        stop_processes(self.processes)

    def advance(
        self,
        duration_s: float,
        should_stop: Callable[[], bool],
    ) -> None:
        """Run the simulation for ``duration_s`` simulated seconds (inf: until ``should_stop``).

        Paced: simulated time follows the wall clock from the session's start at ``speed``
        (a later call continues the same timeline, so the processes' clocks stay right).
        Lockstep: as fast as the CPU and the participants allow (``harness.run.lockstep``), at most
        ``max_speed``. The clock file is published at every check of ``should_stop``.
        """
        sim, clock = self.sim, self.clock

        def check() -> bool:
            clock.publish(sim.time_s)
            return should_stop()

        duration_s = duration_s if duration_s > 0 else math.inf
        if self.speed is None:
            run_gated(sim, fleet_gate(sim, self.acks, self.max_speed), duration_s, check)
            return
        origin = self.wall_start_s + (sim.time_s - self.sim_start_s) / self.speed
        sim.run_paced(self.speed, check, duration_s, wall_origin_s=origin)
