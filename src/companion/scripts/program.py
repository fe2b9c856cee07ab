"""How a scenario's companion program starts and ends: its options, its environment, its exit.

A companion started by ``swarmsitl run`` learns everything from ``SWARMSITL_*`` variables
(:class:`~companion.scenario_env.ScenarioEnv`); run by hand, command-line options override them.
It ends by writing ``result.json`` and exiting 0, or printing its traceback (for the run's report)
and exiting 1.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import faulthandler
import logging
import os
import signal
import sys
import traceback
from collections.abc import Callable, Coroutine, Mapping
from pathlib import Path
from typing import Any, NoReturn, TypeVar

from companion.scenario_env import ScenarioEnv

OPTIONS = {
    "url": "MAVLINK_URL",
    "grpc_port": "GRPC_PORT",
    "vehicle": "VEHICLE",
    "role_index": "ROLE_INDEX",
    "role_count": "ROLE_COUNT",
    "out": "OUT",
    "world": "WORLD",
    "origin": "ORIGIN",
    "video_uri": "VIDEO_URI",
    "duration": "DURATION_S",
    "params": "PARAMS",
}
"""Command-line option (``--grpc-port``) -> the variable it overrides (``SWARMSITL_GRPC_PORT``)."""
TEARDOWN_WALL_S = 2.0
"""Longest wait, wall s, for the tasks a flight left running to end once cancelled."""

T = TypeVar("T")


def parser(description: str, world_example: str, params_example: str) -> argparse.ArgumentParser:
    """The options of a companion program (each overrides its ``SWARMSITL_*`` variable)."""
    ap = argparse.ArgumentParser(
        description=description, formatter_class=argparse.RawTextHelpFormatter
    )
    ap.add_argument("--url", help="MAVSDK connection URL, e.g. udpin://0.0.0.0:14540")
    ap.add_argument("--grpc-port", type=int, help="port of this mavsdk_server, e.g. 50051")
    ap.add_argument("--vehicle", type=int, help="MAVLink system id, e.g. 1")
    ap.add_argument("--role-index", type=int, help="this vehicle's share, 0-based, e.g. 0")
    ap.add_argument("--role-count", type=int, help="vehicles of the role, e.g. 3")
    ap.add_argument("--out", type=Path, help="where result.json goes, e.g. runs/me")
    ap.add_argument("--world", type=Path, help=f"world YAML, e.g. {world_example}")
    ap.add_argument("--origin", help="LAT,LON,ALT_AMSL of world ENU 0,0,0, e.g. 47.3977,8.5456,488")
    ap.add_argument("--video-uri", help="camera stream, e.g. http://127.0.0.1:5600/video.mjpg")
    ap.add_argument("--duration", type=float, help="simulated s the run lasts, e.g. 120")
    ap.add_argument("--params", help=f"JSON of the role args, e.g. '{params_example}'")
    return ap


def scenario_env(args: argparse.Namespace, environ: Mapping[str, str]) -> ScenarioEnv:
    """The ``SWARMSITL_*`` variables, overridden by the options given on the command line."""
    merged = dict(environ)
    for option, name in OPTIONS.items():
        value = getattr(args, option, None)
        if value is not None:
            merged["SWARMSITL_" + name] = str(value)
    merged.setdefault("SWARMSITL_MAVLINK_URL", "udpin://0.0.0.0:14540")
    merged.setdefault("SWARMSITL_VEHICLE", "1")
    return ScenarioEnv.from_env(merged)


def run_flight(flight: Coroutine[Any, Any, T], teardown_wall_s: float = TEARDOWN_WALL_S) -> T:
    """``asyncio.run(flight)`` whose clean-up after the flight cannot hold the program up.

    ``asyncio.run`` waits without a limit for every task left running (telemetry streams of
    a mavsdk_server the flight already stopped) to end once cancelled: the only unbounded wait
    between a flight's end and its ``result.json``. A CI run saw a coverage program that had
    landed and disarmed still without its result when the run ended. Here the leftovers get
    ``teardown_wall_s``; the program exits right after (:func:`finish`), so nothing is lost.
    """
    loop = asyncio.new_event_loop()
    asyncio.set_event_loop(loop)
    try:
        return loop.run_until_complete(flight)
    finally:
        left = [task for task in asyncio.all_tasks(loop) if not task.done()]
        for task in left:
            task.cancel()
        if left:
            loop.run_until_complete(asyncio.wait(left, timeout=teardown_wall_s))
        asyncio.set_event_loop(None)


async def return_after_failure(drone: Any, program: str, timeout_wall_s: float = 10.0) -> None:
    """A flight failed in the air: ask the vehicle to return to launch, once, without raising.

    If the request does not go through within ``timeout_wall_s``, the vehicle's own failsafe
    (link loss, low battery) takes over; the flight's exception is what the caller re-raises.
    """
    try:
        await asyncio.wait_for(drone.action.return_to_launch(), timeout_wall_s)
        print(f"[{program}] error: returning to launch", file=sys.stderr, flush=True)
    except Exception:  # the vehicle's own failsafe takes over
        pass


def _show_mavsdk_server_log() -> None:
    """Print what mavsdk_server says (mavsdk_grpc hands it to the ``mavsdk_server`` logger).

    Its info lines (system discovered, gRPC server started) date a slow or stuck connection
    in the companion's log; without a handler only its warnings would show.
    """
    logger = logging.getLogger("mavsdk_server")
    if not logger.handlers:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("[mavsdk_server] %(levelname)s %(message)s"))
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        logger.propagate = False


def _report_and_die(signum: int, _frame: Any) -> None:
    """SIGTERM: print where each asyncio task waits, then die of the signal as before."""
    with contextlib.suppress(Exception):  # a report on the way out must not mask the signal
        loop = asyncio.get_event_loop_policy().get_event_loop()
        for task in asyncio.all_tasks(loop):
            print(f"asyncio task {task.get_name()}:", file=sys.stderr)
            task.print_stack(file=sys.stderr)
    sys.stderr.flush()
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def finish(
    fly: Callable[[ScenarioEnv], Mapping[str, tuple[Any, str]]],
    env_of: Callable[[], ScenarioEnv],
    log: Callable[..., None],
) -> NoReturn:
    """Fly, write result.json and exit 0; on any failure print the traceback and exit 1.

    ``os._exit``: mavsdk_grpc leaves a non-daemon log thread behind, which would keep the
    process alive after the flight.
    """
    # Stopped by the runner (SIGTERM: the run ended first), the log tells where it stood:
    # every thread's stack at once (faulthandler), then each waiting coroutine's.
    signal.signal(signal.SIGTERM, _report_and_die)
    _show_mavsdk_server_log()
    faulthandler.register(signal.SIGTERM, file=sys.stderr, all_threads=True, chain=True)
    rc = 0
    try:
        env = env_of()
        metrics = fly(env)
        path = env.write_result(metrics)
        log("result", path=str(path), **{k: v[0] for k, v in metrics.items()})
    except Exception:  # any failure: the traceback for the runner's report, exit 1
        traceback.print_exc(file=sys.stderr)
        rc = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(rc)
