"""Machinery of the conformance clients: one API-neutral handle on a vehicle, and a check log.

A conformance client is written once for both MAVSDK-Python APIs. :class:`Api` hides the
differences that are not part of what is tested: how the connection is made (classic
``mavsdk_grpc.System`` with its own ``mavsdk_server``; native ``mavsdk.asyncio.Mavsdk`` with the
C++ core in-process), how a plugin is reached (``drone.action`` / ``ActionAsync(system)``) and how
a stream is opened (``telemetry.position()`` / ``telemetry.subscribe_position()``). Calls, types,
results and errors are each API's own.

:class:`Checks` records each named check as ``{"ok": True, ...values}`` or ``{"ok": False,
"error": ..., "result": <MAVSDK result name>}`` in the report's ``checks``; the tests assert on
them one by one. A failing check aborts its group (later checks of the group are missing), never
the whole client.

The helpers of the e2e clients (``tests/e2e/clients``) are reused, not copied: clients import
them from here, which puts that folder on ``sys.path`` first.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "e2e" / "clients"))

from _common import (
    ClientError,
    Report,
    SimTimeout,
    collect,
    connect_healthy,
    first,
    horizontal,
    native_autopilot,
    ned_of,
    run,
    sim_sleep,
    until,
    wait_for,
    within,
)
from _plans import mission_items, result_name

__all__ = [
    "SEEN_S",
    "Api",
    "Checks",
    "ClientError",
    "Report",
    "SimTimeout",
    "client_main",
    "collect",
    "first",
    "horizontal",
    "mission_items",
    "ned_of",
    "outcome",
    "result_name",
    "run",
    "until",
    "wait_for",
    "within",
]

CONNECT_TIMEOUT_S = 120.0
"""Simulated seconds to connect and see global position and home OK."""
SEEN_S = 30.0
"""Simulated seconds for the client to see a state the vehicle reaches at once (a flight mode
in its next 1 Hz HEARTBEAT, the first item of a stream). Generous on purpose: the lockstep
bounds the simulation's lead over a live client process, not over its event loop's backlog, so
a client starved of CPU sees such a state up to ``--max-speed`` times its lag late."""


RECONNECT_GRPC_OFFSET = 5
"""gRPC port offset of a reconnected classic client (inside the module's port block of 10)."""


class Api:
    """One vehicle as seen through either MAVSDK-Python API."""

    def __init__(self, kind: str, handle, stack: contextlib.AsyncExitStack) -> None:
        self.kind = kind
        """``classic`` (mavsdk_grpc) or ``native`` (mavsdk 4.x)."""
        self._handle = handle
        self._stack = stack
        self._plugins: dict[str, object] = {}
        self._how: tuple[str, int, Report] | None = None

    @classmethod
    async def connect(cls, kind: str, url: str, grpc_port: int, r: Report) -> Api:
        """Connect and wait for global position and home (stages recorded in ``r``)."""
        stack = contextlib.AsyncExitStack()
        if kind == "classic":
            from mavsdk_grpc import System

            drone = System(port=grpc_port)
            stack.callback(drone._stop_mavsdk_server)
            await connect_healthy(drone, url, r, CONNECT_TIMEOUT_S)
            api = cls(kind, drone, stack)
            api._how = (url, grpc_port, r)
            return api
        from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

        config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
        sdk = await stack.enter_async_context(Mavsdk(config))
        r["mavsdk_version"] = await sdk.version()
        system = await native_autopilot(sdk, url, r, CONNECT_TIMEOUT_S)
        api = cls(kind, system, stack)
        api._how = (url, grpc_port, r)
        return api

    async def close(self) -> None:
        await self._stack.aclose()

    async def reconnect(self) -> None:
        """Disconnect and connect again, as a user restarting a script does.

        The classic API's new mavsdk_server gets the other gRPC port of the pair (port, port +
        RECONNECT_GRPC_OFFSET): the old server may not have released its port yet when the new
        one starts, which made the reconnect fail now and then ("connection refused").
        """
        await self.close()
        url, grpc_port, r = self._how
        if self.kind == "classic":
            base = self._grpc_base if hasattr(self, "_grpc_base") else grpc_port
            grpc_port = base + RECONNECT_GRPC_OFFSET if grpc_port == base else base
        fresh = await Api.connect(self.kind, url, grpc_port, r)
        base_port = getattr(self, "_grpc_base", self._how[1])
        self.__dict__.update(fresh.__dict__)
        self._grpc_base = base_port

    def plugin(self, name: str):
        """The plugin ``name`` (``action``, ``mission_raw``, ...) of this vehicle."""
        if name not in self._plugins:
            if self.kind == "classic":
                self._plugins[name] = getattr(self._handle, name)
            else:
                module = importlib.import_module(f"mavsdk.asyncio.plugins.{name}")
                cls = getattr(module, "".join(p.capitalize() for p in name.split("_")) + "Async")
                self._plugins[name] = cls(self._handle)
        return self._plugins[name]

    def types(self, name: str):
        """The module holding plugin ``name``'s types (MissionItem, FlightMode, ...)."""
        prefix = "mavsdk_grpc" if self.kind == "classic" else "mavsdk.asyncio.plugins"
        return importlib.import_module(f"{prefix}.{name}")

    def has(self, plugin: str, call: str) -> bool:
        """True if this API offers ``plugin.call`` (streams by their classic name)."""
        obj = self.plugin(plugin)
        return hasattr(obj, call) or hasattr(obj, f"subscribe_{call}")

    def stream(self, plugin: str, name: str) -> AsyncIterator:
        """A fresh subscription to stream ``name`` (classic name, e.g. ``position``)."""
        obj = self.plugin(plugin)
        if self.kind == "classic":
            return getattr(obj, name)()
        return getattr(obj, f"subscribe_{name}")()

    def telemetry(self, name: str) -> AsyncIterator:
        return self.stream("telemetry", name)

    async def now(self, name: str):
        """The next item of telemetry stream ``name`` (within 30 simulated seconds)."""
        return await within(first(self.telemetry(name)), 30, f"telemetry {name}")

    async def sim_sleep(self, seconds: float) -> None:
        """Sleep ``seconds`` of simulated time (the simulation's clock)."""
        await sim_sleep(seconds)

    async def until(self, name: str, predicate: Callable, sim_s: float, what: str):
        """First item of telemetry stream ``name`` with ``predicate``, within ``sim_s``
        simulated seconds."""
        return await wait_for(self.telemetry(name), predicate, sim_s, what)


class Checks:
    """Named checks of one client run, stored in ``report["checks"]``."""

    def __init__(self, r: Report) -> None:
        self.r = r
        self.log: dict[str, dict] = {}
        r["checks"] = self.log

    async def run(self, name: str, body: Callable[[], Awaitable[dict | None]]) -> dict:
        """Run ``body`` as check ``name``; its dict (or {}) is recorded with ok=True.

        An exception is recorded (with the MAVSDK result name when there is one) and raised
        again, so the group stops.
        """
        self.r.stage(name)
        try:
            values = await body() or {}
        except Exception as exc:
            self.log[name] = {"ok": False, "error": f"{type(exc).__name__}: {exc}"}
            self.log[name]["result"] = result_name(exc)
            raise
        self.log[name] = {"ok": True, **values}
        return values

    async def group(self, name: str, body: Callable[[], Awaitable[None]]) -> None:
        """Run a group of checks; a failure ends the group and is noted, the client goes on.

        The note names the check that failed (``at_check``), or None when the group failed
        between checks: then no check's test reports it, and the run's completeness test does.
        """
        self.r.stage(f"group {name}")
        try:
            await body()
        except Exception as exc:
            at = self.r.get("stage")
            failed_check = at if self.log.get(at, {}).get("ok") is False else None
            self.r.setdefault("aborted_groups", {})[name] = {
                "error": f"{type(exc).__name__}: {exc}",
                "at_check": failed_check,
            }


async def outcome(call: Awaitable, timeout_sim_s: float = 10.0) -> str:
    """``SUCCESS``, the MAVSDK result name of the error raised, or ``NO_ANSWER`` (nothing
    within ``timeout_sim_s`` simulated seconds)."""
    try:
        await within(call, timeout_sim_s, "an answer")
    except SimTimeout:
        return "NO_ANSWER"
    except Exception as exc:
        return result_name(exc)
    return "SUCCESS"


def client_main(
    flow: Callable[[Api, argparse.Namespace, Report], Awaitable[None]],
    options: Callable[[argparse.ArgumentParser], None] = lambda ap: None,
    timeout_sim_s: float = 1600.0,
) -> None:
    """Command line (``--api``, ``--url``, ``--grpc-port``, ``options``), connect, run ``flow``.

    Prints the report as one JSON line and exits (see ``_common.run``).
    """  # fmt: skip
    ap = argparse.ArgumentParser()
    ap.add_argument("--api", choices=("classic", "native"), required=True)
    ap.add_argument("--url", required=True)
    ap.add_argument("--grpc-port", type=int, default=0)
    options(ap)
    args = ap.parse_args()

    async def main_flow(r: Report) -> None:
        api = await Api.connect(args.api, args.url, args.grpc_port, r)
        r["api"] = api.kind
        try:
            await flow(api, args, r)
            r.stage("done")
        finally:
            await api.close()

    run(lambda report: within(main_flow(report), timeout_sim_s, "the whole flow"), Report())
