"""A scenario's ``faults:`` at full fidelity: one vehicle crashed mid-hover, the run goes on.

One lockstep ``swarmsitl run`` (free ports, the project's pytest plugin): two hexacopters take
off and hover under a small MAVSDK companion (written beside the scenario); vehicle 2 crashes
at 18 s. Its autopilot terminates the flight, it falls to the ground and stays there; its
companion keeps running to its end and says what it saw; vehicle 1 flies on, lands and the run
passes. A second fault, due after the run is done, is reported not applied.
"""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.e2e

CRASH_S = 18.0
HOVER_UNTIL_S = 27.0
ALTITUDE_M = 6.0

COMPANION = '''
"""Take off, hover until a simulated time, land if still armed; say what it saw."""

import asyncio
import os

from companion import clock
from companion.scenario_env import ScenarioEnv


async def until(stream, predicate, timeout_s):
    start = clock.now_s()
    async for item in stream:
        if predicate(item):
            return item
        if clock.now_s() - start > timeout_s:
            raise TimeoutError("waited too long")


async def fly(env):
    from mavsdk_grpc import System

    args = env.params
    drone = System(port=env.grpc_port)
    try:
        await drone.connect(system_address=env.mavlink_url)
        await until(drone.core.connection_state(), lambda s: s.is_connected, 60)
        await until(
            drone.telemetry.health(),
            lambda h: h.is_global_position_ok and h.is_home_position_ok,
            60,
        )
        await drone.action.set_takeoff_altitude(args["altitude_m"])
        await drone.action.arm()
        await drone.action.takeoff()
        while clock.now_s() < args["hover_until_s"]:
            await clock.sleep(0.5)
        armed = await until(drone.telemetry.armed(), lambda a: True, 10)
        if armed:
            await drone.action.land()
            await until(drone.telemetry.armed(), lambda a: not a, 60)
        env.write_result(
            {"armed_after_hover": (int(armed), "bool"), "ended_s": (clock.now_s(), "s")}
        )
    finally:
        drone._stop_mavsdk_server()


if __name__ == "__main__":
    asyncio.run(fly(ScenarioEnv.from_env()))
    os._exit(0)
'''


def test_a_crashed_vehicle_falls_its_companion_runs_on_the_other_lands(swarmsitl_run, tmp_path):
    (tmp_path / "hover.py").write_text(textwrap.dedent(COMPANION))
    scenario = {
        "name": "crash-one",
        "seed": 2,
        "duration_s": 80,
        "spacing_m": 5,
        "fleet": [{"role": "hover", "count": 2}],
        "roles": {
            "hover": {
                "script": "hover.py",
                "args": {"altitude_m": ALTITUDE_M, "hover_until_s": HOVER_UNTIL_S},
            }
        },
        "sensors": {"cameras": False, "rangefinders": False},
        "checks": {"landed_and_disarmed": True, "no_failsafe": True},
        "faults": [
            {"kind": "crash", "vehicle": 2, "at_s": CRASH_S},
            {"kind": "land", "vehicle": 1, "at_s": 75},  # the run is done before
        ],
    }
    path = tmp_path / "crash.yaml"
    path.write_text(yaml.safe_dump(scenario, sort_keys=False))

    result = swarmsitl_run(path)  # lockstep, free ports

    report = result.report
    result.assert_passed()
    assert report["stop_reason"] == "done", report["stop_reason"]
    crash, late = report["faults"]
    assert crash["vehicle"] == "vehicle2" and crash["kind"] == "crash" and crash["applied"]
    assert CRASH_S <= crash["time_s"] < CRASH_S + 0.01, crash
    assert late == {
        "vehicle": "vehicle1",
        "kind": "land",
        "time_s": None,
        "due_s": 75.0,
        "entry": 1,
        "applied": False,
    }
    assert report["vehicles"]["vehicle2"]["fault"] == "crash"
    assert "fault" not in report["vehicles"]["vehicle1"]

    # vehicle 2 was flying (how far up its climb depends on when its companion got to take off,
    # which a loaded machine delays), then fell to the ground within 2 s of the crash and stayed
    # there
    track = result.log.vehicle(1).track
    t, up = track.time_s, track.enu_m[:, 2]
    ground = up[0]
    before = (t > CRASH_S - 2.0) & (t < CRASH_S)
    assert np.all(up[before] - ground > 1.0), up[before] - ground
    after = t >= CRASH_S + 2.0
    assert np.all(np.isfinite(up)) and np.all(np.abs(up[after] - ground) < 0.5)
    assert track.columns["armed"][after].max() == 0.0

    # its companion ran on past the crash to its own end, and found its vehicle disarmed
    v2 = report["vehicles"]["vehicle2"]["companion"]
    assert v2["armed_after_hover"]["value"] == 0
    assert v2["ended_s"]["value"] >= HOVER_UNTIL_S
    assert report["companions"]["vehicle2"]["exit_code"] == 0
    assert report["companions"]["vehicle2"]["exit_time_s"] >= HOVER_UNTIL_S

    # vehicle 1 hovered on, landed when its companion told it to
    assert report["vehicles"]["vehicle1"]["companion"]["armed_after_hover"]["value"] == 1
    track1 = result.log.vehicle(0).track
    t1, up1 = track1.time_s, track1.enu_m[:, 2]
    hover = (t1 > CRASH_S) & (t1 < HOVER_UNTIL_S)
    assert np.all(np.abs(up1[hover] - up1[0] - ALTITUDE_M) < 1.0)
    result.assert_landed_and_disarmed(0)
    message = report["checks"]["landed_and_disarmed"]["message"]
    assert "vehicle2 crashed: judged on disarming only" in message, message
