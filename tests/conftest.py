"""The suite's tiers, their guard, and their scheduling on parallel workers (docs/testing.md).

**Tiers.** A test is in the *unit* tier unless a marker puts it elsewhere: ``sockets`` (it binds
sockets, port 0 too, and may sleep), ``process`` (it starts processes; sockets and sleeps too),
``heavy`` (a process-tier test with several busy processes at once: a Dask cluster, a lockstep
run with its companions), ``e2e`` (end to end: implies ``heavy``); every module of
``tests/e2e`` and ``tests/conformance`` is the *e2e* group (``swarmsitl up --lockstep
--max-speed 4`` with real clients). While
an unmarked test runs (its call, and the setup of its function-scoped fixtures), starting a
process (``subprocess.Popen``, ``os.fork``/``posix_spawn``/``system``, ``multiprocessing``),
binding a socket (``socket.socket.bind``) or a ``time.sleep`` over 0.1 s raises
:class:`TierError`, naming the call and the marker that allows it. Fixtures of wider scope
(module, session) are not guarded: they are built once for many tests and hold the servers,
clusters and runs those tests share, and pytest's, xdist's and numba's machinery runs outside
any test. ``SWARMSITL_TIER_RECORD=<file>`` appends each violation to the file instead (one
pass over the suite lists them all).

**Scheduling.** With ``--dist loadgroup`` (``.ci/run``: ``-n 2``) :class:`TieredScheduling`
sends each test module whole to one worker (its module-scoped fixtures are built once) and the
whole e2e group to one worker, one module after another: two e2e runs never compete for the
CPU. The e2e group never runs beside a heavy module either (its processes would take the
e2e run's CPU: its waits are in simulated time, but a starved run is a slow one and its
start-up and a few limits are wall-clock): while it runs, the other worker takes the other
modules (one busy process at a time, a core's worth), and the heavy ones (lockstep runs, Dask
clusters: their outcome does not depend on the load) come after it, on both workers. The
controller collects no tests, so a unit's kind is read from node ids and sources: the e2e
directories, else a module whose source says ``mark.heavy``, ``mark.e2e`` or ``mark.stress``
is heavy; :func:`pytest_collection_modifyitems` refuses a heavy test whose module's source
does not say so. Without ``-n`` (or with another ``--dist``) nothing is reordered.

pytest-xdist's own ``xdist_group`` markers are not used: with pytest 9 the group suffix it
writes into the node id is lost, and the groups are silently ignored.

**A shared fixture fails one test.** When a module- or session-scoped fixture fails, pytest
raises the same error again in every test that uses it; here the first test reports the error
and the others are skipped with a pointer to it ("not run: ... failed in <first test>").

**Compiled kernels.** Before any test runs, the main process fills the cache of the compiled
kernels (numba) in a subprocess, ``python -m harness.kernels`` (``harness.kernels.compile_all``:
every kernel in ``src/``, with every signature the stack calls it with): the workers, and every
``swarmsitl up`` or scenario subprocess a test starts, then load them instead of compiling them
(tens of seconds on a cold machine, which would eat into an end-to-end test's wall-clock limits).

The e2e group then forbids compiling: around each of its tests
``SWARMSITL_FORBID_JIT_COMPILE=1`` is set (every ``swarmsitl`` process started from then on
raises on a kernel compile, and appends the kernel to ``SWARMSITL_JIT_COMPILE_LOG``) and the
same guard runs in the test's own process. A compile during the test, in any of them, fails it
at teardown with the kernel's name, instead of a timeout somewhere else. Loading from the warm
cache is not a compile (numba's ``numba:compile`` event fires on cache misses only).
"""

from __future__ import annotations

import contextlib
import functools
import multiprocessing.process
import os
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Collection, Generator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from harness.kernels import (
    COMPILE_LOG_ENV,
    FORBID_COMPILE_ENV,
    CompileGuard,
    allow_compiles,
    forbid_compiles,
)

pytest_plugins = ["pytester"]
"""pytester runs a user's test file in a subprocess (the swarmsitl pytest plugin's own tests)."""

ROOT = Path(__file__).resolve().parents[1]
"""The repository root: node ids are relative to it."""

# --- tiers -----------------------------------------------------------------------------------

E2E_DIRS = ("tests/e2e/", "tests/conformance/")
"""Node-id prefixes (relative to the repository root) of the modules in the e2e group."""
E2E_GROUP = "e2e"
LIGHT, HEAVY, E2E = "light", "heavy", "e2e"
"""Kinds of work unit, as the scheduler sees them: a module of the unit, sockets or process
tier (one busy process at a time: a core's worth, like the worker itself), a module marked
``heavy`` (several busy processes at once), the e2e group."""
PROCESS_MARKERS = ("process", "heavy", "e2e", "stress")
"""Markers of the process tier: each lets a test start processes (and bind, and sleep)."""
HEAVY_MARKERS = ("heavy", "e2e", "stress")
"""Markers that make a test, and for the scheduler its whole module, heavy."""
HEAVY_MARK_RE = re.compile(r"\bmark\.(?:" + "|".join(HEAVY_MARKERS) + r")\b")
"""How the scheduler, which sees node ids only, finds them in a module's source."""
SLEEP_LIMIT_S = 0.1
"""The longest single ``time.sleep`` a unit-tier test may make."""
TIER_RECORD_ENV = "SWARMSITL_TIER_RECORD"
"""A file: the guard appends ``nodeid<TAB>rule<TAB>call`` there instead of failing the test."""
RULE_MARKERS = {"process": "process", "socket": "sockets", "sleep": "sockets"}
"""The rules of the unit tier, each with the marker that lifts it."""
MARKER_ALLOWS = {
    **{marker: frozenset(RULE_MARKERS) for marker in PROCESS_MARKERS},
    "sockets": frozenset({"socket", "sleep"}),
}
"""The rules each marker lifts."""


def scope_of(nodeid: str) -> str:
    """The work unit of a test: the e2e group, or its module."""
    module = nodeid.split("::", 1)[0]
    return E2E_GROUP if module.startswith(E2E_DIRS) else module


@functools.cache
def kind_of(scope: str) -> str:
    """What a work unit (:func:`scope_of`) is to the scheduler: e2e, heavy (its source says
    ``mark.heavy``, ``mark.e2e`` or ``mark.stress``) or light."""
    if scope == E2E_GROUP:
        return E2E
    try:
        source = (ROOT / scope).read_text(encoding="utf-8")
    except OSError:
        return LIGHT
    return HEAVY if HEAVY_MARK_RE.search(source) else LIGHT


def is_heavy(item: pytest.Item) -> bool:
    return any(item.get_closest_marker(marker) is not None for marker in HEAVY_MARKERS)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Refuse a heavy test outside the e2e group whose module's source does not say so (a
    marker applied from elsewhere): the scheduler, which reads sources, would run it beside
    the e2e group."""
    wrong = sorted(
        {
            scope_of(item.nodeid)
            for item in items
            if is_heavy(item) and kind_of(scope_of(item.nodeid)) == LIGHT
        }
    )
    if wrong:
        raise pytest.UsageError(
            "tests/conftest.py: heavy tests in modules whose source does not say so (the "
            f"scheduler reads `mark.heavy`/`mark.e2e`/`mark.stress`): {', '.join(wrong)}; "
            "mark them in the module itself"
        )


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: object) -> object | None:
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    rank = {E2E: 0, LIGHT: 1, HEAVY: 2}

    class TieredScheduling(LoadScopeScheduling):
        """Module (and e2e group) work units; the e2e group never beside a heavy unit.

        A worker asking for work gets the first unit, e2e group first, then light modules,
        then heavy ones (each in xdist's order: most tests first), that may run beside what the
        other workers have not finished; if none may, it waits and is asked again whenever a
        test ends anywhere.
        """

        def _split_scope(self, nodeid: str) -> str:
            return scope_of(nodeid)

        def _tiers_elsewhere(self, node: object) -> set[str]:
            return {
                kind_of(scope)
                for other, units in self.assigned_work.items()
                if other is not node
                for scope, tests in units.items()
                if not all(tests.values())
            }

        def _assign_work_unit(self, node: object) -> None:
            self.assigned_work.setdefault(node, {})
            elsewhere = self._tiers_elsewhere(node)
            blocked = {
                E2E: {E2E, HEAVY} & elsewhere,
                HEAVY: {E2E} & elsewhere,
                LIGHT: set(),
            }
            order = sorted(self.workqueue, key=lambda scope: rank[kind_of(scope)])
            scope = next((s for s in order if not blocked[kind_of(s)]), None)
            if scope is None:
                return  # waits: asked again when a test ends (mark_test_complete)
            work_unit = self.workqueue.pop(scope)
            self.assigned_work[node][scope] = work_unit
            collection = self.registered_collections[node]
            node.send_runtest_some(
                [collection.index(nodeid) for nodeid, done in work_unit.items() if not done]
            )

        def mark_test_complete(self, node: object, item_index: int, duration: float = 0) -> None:
            super().mark_test_complete(node, item_index, duration)
            for other in self.nodes:
                if other is not node and not other.shutting_down:
                    self._reschedule(other)

    return TieredScheduling(config, log)


class TierError(RuntimeError):
    """A unit-tier test started a process, bound a socket or slept too long."""


@dataclass
class _TierGuard:
    nodeid: str
    allowed: frozenset[str]
    thread: int
    """The test's thread: only its sleeps count (a shared server's threads may sleep)."""
    violations: list[str] = field(default_factory=list)


_tier_guard: _TierGuard | None = None
"""The guard of the test (or function-scoped fixture) running now; None between them."""


def allowed_rules(item: pytest.Item) -> frozenset[str]:
    """The rules the test's markers lift (all of them in the e2e group)."""
    if scope_of(item.nodeid) == E2E_GROUP:
        return frozenset(RULE_MARKERS)
    allowed: frozenset[str] = frozenset()
    for marker, rules in MARKER_ALLOWS.items():
        if item.get_closest_marker(marker) is not None:
            allowed |= rules
    return allowed


def _violate(rule: str, call: str) -> None:
    guard = _tier_guard
    if guard is None or rule in guard.allowed:
        return
    if rule == "sleep" and threading.get_ident() != guard.thread:
        return
    marker = RULE_MARKERS[rule]
    message = (
        f"unit tier: {call} in {guard.nodeid}. A test without a tier marker starts no "
        f"process, binds no socket and sleeps at most {SLEEP_LIMIT_S} s at a time "
        f"(tests/conftest.py; docs/testing.md, Tiers). If it must, mark it "
        f"@pytest.mark.{marker} (a whole module: pytestmark = pytest.mark.{marker})"
    )
    guard.violations.append(message)
    record = os.environ.get(TIER_RECORD_ENV)
    if record:
        with open(record, "a") as out:
            out.write(f"{guard.nodeid}\t{rule}\t{call}\n")
        return
    raise TierError(message)


def _guarded(rule: str, original: Callable, describe: Callable[..., str]) -> Callable:
    @functools.wraps(original)
    def guarded(*args, **kwargs):
        if _tier_guard is not None:
            _violate(rule, describe(*args, **kwargs))
        return original(*args, **kwargs)

    return guarded


def _install_tier_guard() -> None:
    """Wrap the calls the unit tier forbids, once; outside a guarded test they pass through.

    Wrapped where every caller goes through them: ``subprocess.Popen._execute_child`` (also
    ``asyncio``'s subprocesses, ``os.popen``), ``os.fork``, ``os.forkpty``, ``os.posix_spawn``,
    ``os.posix_spawnp``, ``os.system``, ``multiprocessing``'s ``Process.start`` (every start
    method, process pools), ``socket.socket.bind`` and ``time.sleep``. A module that bound
    ``from time import sleep`` before this conftest was imported keeps the original.
    """
    if getattr(time.sleep, "__wrapped__", None) is not None:
        return
    original_sleep = time.sleep

    @functools.wraps(original_sleep)
    def sleep(seconds: float) -> None:
        if _tier_guard is not None and seconds > SLEEP_LIMIT_S:
            _violate("sleep", f"time.sleep({seconds})")
        original_sleep(seconds)

    time.sleep = sleep
    socket.socket.bind = _guarded(  # type: ignore[method-assign]
        "socket", socket.socket.bind, lambda sock, address: f"socket.bind({address!r})"
    )
    subprocess.Popen._execute_child = _guarded(  # type: ignore[attr-defined]
        "process",
        subprocess.Popen._execute_child,  # type: ignore[attr-defined]
        lambda popen, args, *rest, **kwargs: f"subprocess.Popen({args!r})",
    )
    multiprocessing.process.BaseProcess.start = _guarded(  # type: ignore[method-assign]
        "process",
        multiprocessing.process.BaseProcess.start,
        lambda process: f"multiprocessing {type(process).__name__}.start()",
    )
    for name in ("fork", "forkpty", "posix_spawn", "posix_spawnp", "system"):
        if hasattr(os, name):
            describe = functools.partial(lambda name, *args, **kwargs: f"os.{name}()", name)
            setattr(os, name, _guarded("process", getattr(os, name), describe))


_install_tier_guard()


@contextlib.contextmanager
def _guarding(guard: _TierGuard | None) -> Generator[_TierGuard | None]:
    global _tier_guard
    outer, _tier_guard = _tier_guard, guard
    try:
        yield guard
    finally:
        _tier_guard = outer


def _new_guard(item: pytest.Item) -> _TierGuard:
    return _TierGuard(item.nodeid, allowed_rules(item), threading.get_ident())


def _raise_unraised(guard: _TierGuard) -> None:
    """Fail for a violation that did not fail the test itself (another thread, caught)."""
    if guard.violations and not os.environ.get(TIER_RECORD_ENV):
        raise TierError(guard.violations[0])


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Generator:
    """The unit tier's rules hold while the test runs."""
    with _guarding(_new_guard(item)) as guard:
        result = yield
    _raise_unraised(guard)
    return result


@pytest.hookimpl(wrapper=True)
def pytest_fixture_setup(
    fixturedef: pytest.FixtureDef, request: pytest.FixtureRequest
) -> Generator:
    """The rules hold in a function-scoped fixture's setup too (it runs for its one test);
    module- and session-scoped fixtures are shared, and may start what their tests need."""
    item = request.node
    if fixturedef.scope != "function" or not isinstance(item, pytest.Item):
        with _guarding(None):
            return (yield)
    with _guarding(_new_guard(item)) as guard:
        result = yield
    _raise_unraised(guard)
    return result


_setup_errors: dict[int, tuple[BaseException, str]] = {}
"""Errors raised in a test's setup, by id: the error itself and the first test it failed."""


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo) -> Generator:
    """A failed shared fixture fails its first test; the others that use it are skipped.

    pytest keeps a module- or session-scoped fixture's error and raises the same exception
    object in each later test that needs the fixture: those are reported as skipped, naming the
    test that reported the error (the session still fails on that one).
    """
    report = yield
    if call.when != "setup" or not report.failed or call.excinfo is None:
        return report
    error = call.excinfo.value
    first = _setup_errors.get(id(error))
    if first is None or first[0] is not error:
        _setup_errors[id(error)] = (error, item.nodeid)
        return report
    path, line, _ = item.reportinfo()
    report.outcome = "skipped"
    report.longrepr = (
        str(path),
        (line or 0) + 1,
        f"Skipped: not run: a fixture it shares failed in {first[1]} "
        f"({type(error).__name__}, reported there)",
    )
    return report


WARM_KERNELS = [sys.executable, "-m", "harness.kernels"]
"""Loads (or compiles and caches) every kernel of the stack: ``harness.kernels.compile_all``."""


def pytest_sessionstart(session: pytest.Session) -> None:
    """Fill the kernel cache once, in the main process, before xdist starts the workers."""
    if hasattr(session.config, "workerinput"):  # an xdist worker: the main process did it
        return
    env = {k: v for k, v in os.environ.items() if k != FORBID_COMPILE_ENV}
    try:
        subprocess.run(WARM_KERNELS, capture_output=True, timeout=900, check=True, env=env)
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
        # Not fatal here: the e2e tests will fail naming the kernels they compiled.
        stderr = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else ""
        print(f"warming the kernel cache failed: {exc}\n{stderr}", file=sys.stderr)


def is_e2e(item: pytest.Item) -> bool:
    """Whether a test is in the e2e group (tests/e2e, tests/conformance)."""
    return scope_of(item.nodeid) == E2E_GROUP


COMPILE_LOG = Path(tempfile.gettempdir()) / f"swarmsitl-jit-compiles-{os.getpid()}.log"
"""This test process's log of forbidden compiles (its own and its subprocesses')."""
_LOG_START = pytest.StashKey[int]()
_guard: CompileGuard | None = None
"""The in-process compile guard of the running e2e test."""


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    """Forbid kernel compiles for a e2e test: in the processes it starts, and here.

    Set before the test's fixtures run (module-scoped ones start ``swarmsitl up`` processes,
    which keep the setting for their lifetime) and kept until its teardown ends.
    """
    global _guard
    if not is_e2e(item):
        return
    COMPILE_LOG.touch()
    item.stash[_LOG_START] = COMPILE_LOG.stat().st_size
    os.environ[FORBID_COMPILE_ENV] = "1"
    os.environ[COMPILE_LOG_ENV] = str(COMPILE_LOG)
    if _guard is None:
        _guard = forbid_compiles(COMPILE_LOG)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item: pytest.Item, nextitem: pytest.Item | None) -> Generator:
    """Fail a e2e test in whose processes a kernel compiled (names the kernels)."""
    global _guard
    result = yield
    if _LOG_START not in item.stash:
        return result
    if _guard is not None:
        allow_compiles(_guard)
        _guard = None
    os.environ.pop(FORBID_COMPILE_ENV, None)
    os.environ.pop(COMPILE_LOG_ENV, None)
    with COMPILE_LOG.open() as log:
        log.seek(item.stash[_LOG_START])
        compiles = log.read().splitlines()
    if compiles:
        pytest.fail(
            "numba compiled a kernel during this test; the cache filled at the session's start "
            "(harness.kernels.compile_all) should have held it: " + "; ".join(compiles),
            pytrace=False,
        )
    return result


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Remove this process's compile log (its entries failed their tests already)."""
    COMPILE_LOG.unlink(missing_ok=True)


# --- time per tier ---------------------------------------------------------------------------

TIERS = ("unit", "sockets", "process", "heavy", "e2e")
"""The tiers as the terminal summary counts them (docs/testing.md, "Tiers")."""
_tier_totals: dict[str, list[float]] = {tier: [0, 0.0] for tier in TIERS}
"""Tier -> [tests, seconds of set-up, call and teardown], from the reports this process saw."""


def tier_of(nodeid: str, keywords: Collection[str]) -> str:
    """A test's tier: its work unit's kind (:func:`kind_of`), else its marker, else unit."""
    kind = kind_of(scope_of(nodeid))
    if kind != LIGHT:
        return kind
    return next((marker for marker in ("process", "sockets") if marker in keywords), "unit")


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Add the phase's duration to its test's tier (on the controller: every worker's)."""
    totals = _tier_totals[tier_of(report.nodeid, report.keywords)]
    totals[1] += report.duration
    if report.when == "call" or (report.when == "setup" and report.skipped):
        totals[0] += 1


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """Print the suite's time per tier: the sum of its tests' durations over all workers."""
    if not any(count for count, _ in _tier_totals.values()):
        return
    terminalreporter.section("time per tier (sum of test durations over all workers)")
    for tier in TIERS:
        count, seconds = _tier_totals[tier]
        terminalreporter.write_line(f"{tier:8s} {int(count):5d} tests {seconds:8.1f} s")
