"""The stack's compiled kernels (numba): load or compile all of them at once; forbid compiling.

Every ``@numba.njit(cache=True)`` kernel in ``src/`` is listed in :data:`SIGNATURES` with the
argument types its callers pass at run time (a numba dispatcher compiles one machine-code
version per combination of argument types: a call with a new combination compiles, a few
tenths of a second to seconds, and a simulation stands still meanwhile). :func:`compile_all`
loads each of them from numba's on-disk cache, or compiles and caches it if the cache is cold,
without running anything: the test suite calls it before any test (``tests/conftest.py``),
``python -m harness.kernels`` does the same from a shell (a CI image, a fresh install).

The estimator's kernels (``autopilot_emu.estimator_kernels``) declare their one signature
themselves and are loaded when that module is imported. Helpers declared with
``no_cpython_wrapper=True`` cannot be called from Python: they are compiled into their callers
(and cached with them), so they need no entry here.

Layouts differ with the fleet (``sitl.world``): with one vehicle the sensor kernels get
C-contiguous views of the scene's arrays; with several, strided views ('A' layout); in a
fleet of mixed airframes each airframe group's rows are sliced (contiguous members) or
gathered (others); the magnetometer's field array is a read-only broadcast for one vehicle and
a copy for several. Each of these is a signature of its own, and all of them are listed.

:func:`forbid_compiles` is the other half: a numba event listener that turns any compile
(``numba:compile`` fires on a cache miss only; loading from the cache does not fire it) into a
:class:`KernelCompileError` naming the kernel and its argument types. ``swarmsitl`` installs it
when :data:`FORBID_COMPILE_ENV` is ``1`` (:func:`forbid_compiles_if_requested`), so that a test
of the process tier fails at once, and names the kernel, instead of timing out in MAVSDK while
a process compiles.
"""

from __future__ import annotations

import importlib
import os
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from numba import types
from numba.core import event
from numba.core.registry import CPUDispatcher

FORBID_COMPILE_ENV = "SWARMSITL_FORBID_JIT_COMPILE"
"""``1``: every ``swarmsitl`` process (up, run, autopilot, ...) raises on a kernel compile."""
COMPILE_LOG_ENV = "SWARMSITL_JIT_COMPILE_LOG"
"""A file each forbidden compile is appended to (``pid kernel(types)``), for whoever started
the process to find it even when the process's own output is not read (the test hooks)."""

F = types.float64
INT = types.int64
BOOL = types.boolean
F1 = types.float64[::1]
F2 = types.float64[:, ::1]
F3 = types.float64[:, :, ::1]
F2A = types.float64[:, :]
F3A = types.float64[:, :, :]
F2_READ_ONLY = types.Array(types.float64, 2, "C", readonly=True)
B1 = types.boolean[::1]
B2 = types.boolean[:, ::1]
I1 = types.int64[::1]
I2 = types.int64[:, ::1]
"""Argument types, as ``numba.typeof`` gives them for the callers' values (``F``: a float,
``F2``: a C-contiguous 2-D float64 array, ``F2A``: a strided one)."""

Signature = tuple[types.Type, ...]

_NAV = (
    F2, F2, F1, F1, F1, F1, F2, B1, F2, F2, F2, F2, B1, B1, F3, F2, F1, F2, F2, F2, F2, F2, F2, F,
    B1, F2, F1, F2, F1, B1,
)  # fmt: skip
"""The argument list too long for one line."""


SIGNATURES: dict[str, tuple[Signature, ...]] = {
    # -- simulator: physics and sensors ---------------------------------------------------------
    "sitl.physics.rotor_kernel:commands_from_controls": ((F2, F2, F2),),
    "sitl.physics.rotor_kernel:wrench_and_advance": ((F2, F2, F3, F2, F, F, F2),),
    "sitl.physics.state_kernel:complete_state": ((F1, F2, F3),),
    "sitl.physics.state_kernel:wrench_to_world": ((F2, F2, F3),),
    "sitl.sensors.noise_kernel:biased_white_noise": ((F1, F1, F1, F1, F1, F1, F1),),
    "sitl.sensors.noise_kernel:imu_sample": (
        (F3, F2, F2, F2, F, BOOL, F, F3, F3),  # one vehicle; a one-vehicle or gathered group
        (F3A, F2A, F2, F2A, F, BOOL, F, F3, F3A),  # several vehicles of one airframe
        (F3A, F2A, F2, F2A, F, BOOL, F, F3, F3),  # a sliced airframe group of a mixed fleet
    ),
    "sitl.sensors.noise_kernel:field_in_body": (
        (F3, F2_READ_ONLY, F2, F2),  # one vehicle; a one-vehicle airframe group
        (F3A, F2, F2, F2A),  # several vehicles of one airframe
        (F3A, F2, F2, F2),  # a sliced airframe group of a mixed fleet
        (F3, F2, F2, F2),  # a gathered airframe group (members not adjacent)
    ),
    # -- autopilot: per-IMU-sample and 50 Hz chains, battery, HIL input -------------------------
    "autopilot_emu.hil_sensor_kernel:hil_sensor_kernel": ((F2, I1, F1, F3, F1, B2),),
    "autopilot_emu.battery_kernel:battery_kernel": ((F1, F1, F, F, *(F1,) * 13, F2, F3, F1),),
    "autopilot_emu.position_validity_kernel:position_validity": (
        (F, F2, INT, F, B1, F1, F1, F1, B1),
    ),
    "autopilot_emu.control.inner_loop_kernel:inner_loop_kernel": (
        (F2, F2, F2, F1, F3, F3, B1, F2, F, B1, B1, F, F2, F3, B1, F3, F2, B2, F, F1, *(F2,) * 4),
    ),
    "autopilot_emu.control.nav_kernel:nav_kernel": (_NAV,),
    "autopilot_emu.control.hover_thrust_kernel:hover_thrust_tick_kernel": (
        (B1, B1, F2, F1, F3, F2, F, *(F1,) * 12, B1, F1, B1, F1, F2),
    ),
    "autopilot_emu.control.trajectory_kernel:hold_point_kernel": ((F1, F1, F1, F1, F, F, F),),
    "autopilot_emu.nan_scalar:fmin": ((F, F),),
    "autopilot_emu.nan_scalar:fmax": ((F, F),),
    "autopilot_emu.nan_scalar:clamp": ((F, F, F),),
    "autopilot_emu.nan_scalar:sign": ((F,),),
    # -- companion: planners ----------------------------------------------------------------------
    "companion.planning.mco.firefly:firefly_kernel": ((F2, I2, I2, INT, F, F, F, F, INT, INT),),
    "companion.planning.aco.colony:colony_kernel": (
        (I1, I1, I1, F1, F1, F1, F, F, INT, INT, INT, INT, INT),
    ),
    "companion.planning.aco.colony:pheromone_update": ((F1, I2, I1, F1, F),),
}
"""Every lazily compiled kernel (``module:function``) and the argument types it is called with."""

EAGER_KERNEL_MODULES = ("autopilot_emu.estimator_kernels",)
"""Modules whose kernels declare their signatures and compile (or load) when imported."""


@dataclass(frozen=True)
class KernelLoad:
    """What :func:`compile_all` did."""

    signatures: int
    """Signatures made ready (loaded from the cache, compiled, or already in this process)."""
    compiled: tuple[str, ...]
    """Those that were compiled (a cold or stale cache): ``module.function(types)``."""
    seconds: float


def kernel(name: str) -> CPUDispatcher:
    """The dispatcher of ``module:function``."""
    module, _, function = name.partition(":")
    dispatcher = getattr(importlib.import_module(module), function)
    if not isinstance(dispatcher, CPUDispatcher):
        raise TypeError(f"{name} is not a numba kernel")
    return dispatcher


def compile_all() -> KernelLoad:
    """Load every kernel of :data:`SIGNATURES` from numba's cache, compiling what is missing.

    Nothing runs: each signature is handed to its dispatcher, which loads the cached machine
    code (milliseconds) or compiles and caches it (the first run on a machine, or after a
    kernel's source changed). Idempotent: signatures already loaded in this process are free.
    """
    start = time.perf_counter()
    compiled: list[str] = []
    recorder = _CompileRecorder(compiled)
    event.register("numba:compile", recorder)
    try:
        count = 0
        for module in EAGER_KERNEL_MODULES:
            for value in vars(importlib.import_module(module)).values():
                if isinstance(value, CPUDispatcher) and _callable_from_python(value):
                    count += len(value.signatures)
        for name, signatures in SIGNATURES.items():
            dispatcher = kernel(name)
            for signature in signatures:
                dispatcher.compile(signature)
                count += 1
    finally:
        event.unregister("numba:compile", recorder)
    return KernelLoad(count, tuple(compiled), time.perf_counter() - start)


def _callable_from_python(dispatcher: CPUDispatcher) -> bool:
    """False for a helper compiled only into other kernels (``no_cpython_wrapper=True``)."""
    return not dispatcher.targetoptions.get("no_cpython_wrapper", False)


def describe(dispatcher: CPUDispatcher, args: tuple[types.Type, ...]) -> str:
    """``module.function(arg types)`` of a compile."""
    func = dispatcher.py_func
    return f"{func.__module__}.{func.__qualname__}({', '.join(str(a) for a in args)})"


class _CompileRecorder(event.Listener):
    """Notes the outermost compiles (not the helpers and numba internals compiled inside)."""

    def __init__(self, out: list[str]) -> None:
        self.out = out
        self._depth = 0

    def on_start(self, ev: event.Event) -> None:
        if self._depth == 0:
            self.out.append(describe(ev.data["dispatcher"], ev.data["args"]))
        self._depth += 1

    def on_end(self, ev: event.Event) -> None:
        self._depth = max(self._depth - 1, 0)


class KernelCompileError(RuntimeError):
    """A kernel compiled where compiling is forbidden (:func:`forbid_compiles`)."""


class CompileGuard(event.Listener):
    """Raises :class:`KernelCompileError` when numba starts compiling, and keeps a record.

    Numba fires ``numba:compile`` only on a cache miss, so loading cached kernels passes.
    """

    def __init__(self, log_path: Path | None = None) -> None:
        self.log_path = log_path
        self.violations: list[str] = []
        self._lock = threading.Lock()

    def on_start(self, ev: event.Event) -> None:
        """Refuse the compile: record it, append it to the log, raise."""
        what = describe(ev.data["dispatcher"], ev.data["args"])
        with self._lock:
            self.violations.append(what)
            if self.log_path is not None:
                with self.log_path.open("a") as log:
                    log.write(f"{os.getpid()} {what}\n")
        raise KernelCompileError(
            f"numba compiled {what} while compiling was forbidden ({FORBID_COMPILE_ENV}=1): "
            "the kernel cache is cold or stale, or harness.kernels.SIGNATURES lacks this "
            "signature; run `python -m harness.kernels` first, or add the signature"
        )

    def on_end(self, ev: event.Event) -> None:
        """Nothing: the compile was refused at its start."""


def forbid_compiles(log_path: Path | None = None) -> CompileGuard:
    """Make every numba compile in this process raise; undo with :func:`allow_compiles`."""
    guard = CompileGuard(log_path)
    event.register("numba:compile", guard)
    return guard


def allow_compiles(guard: CompileGuard) -> None:
    """Remove a guard installed by :func:`forbid_compiles`."""
    event.unregister("numba:compile", guard)


@contextmanager
def compiles_forbidden(log_path: Path | None = None) -> Iterator[CompileGuard]:
    """:func:`forbid_compiles` for the duration of a ``with`` block."""
    guard = forbid_compiles(log_path)
    try:
        yield guard
    finally:
        allow_compiles(guard)


_env_guard: CompileGuard | None = None


def forbid_compiles_if_requested() -> CompileGuard | None:
    """Install the process-wide guard if :data:`FORBID_COMPILE_ENV` is ``1`` (once per process).

    Called by the ``swarmsitl`` command line before any command runs; the variable passes to
    the processes a run starts (autopilots, bridges) with the rest of the environment.
    """
    global _env_guard
    if os.environ.get(FORBID_COMPILE_ENV) != "1":
        return None
    if _env_guard is None:
        log = os.environ.get(COMPILE_LOG_ENV)
        _env_guard = forbid_compiles(Path(log) if log else None)
    return _env_guard


def main() -> None:
    """``python -m harness.kernels``: fill the kernel cache; print what it took."""
    load = compile_all()
    print(
        f"{load.signatures} kernel signatures ready in {load.seconds:.1f} s "
        f"({len(load.compiled)} compiled, the others were in numba's cache)"
    )
    for what in load.compiled:
        print(f"  compiled {what}", file=sys.stderr)


if __name__ == "__main__":
    main()
