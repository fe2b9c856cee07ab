"""The caravan program's MAVSDK adapter without MAVSDK: what the swarm program decides, it does.

``CaravanProgram`` (the swarm adapter's decisions) drives :class:`MavsdkVehicle` (telemetry in,
queued MAVSDK commands out) and :class:`Radio` (``companion.net`` messages); the e2e run
(tests/harness/test_caravan_kill_e2e.py) flies them on the full stack.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from companion.planning.caravan.scores import CaravanParams
from companion.scenario_env import ScenarioEnv
from companion.scripts.caravan import (
    FULL_STACK_ARRIVE_M,
    MavsdkVehicle,
    Radio,
    full_stack_params,
)
from companion.swarm.caravan import TOPIC, CaravanProgram, task_map
from harness.scenarios import scenario_path
from harness.scenarios.spec import load_scenario

HOME = np.array([-3.0, -3.0, 0.0])


class FakeNode:
    """What :class:`Radio` uses of ``companion.net.AsyncNode``: a handler and broadcasts."""

    def __init__(self) -> None:
        self.handlers: dict = {}
        self.sent: list = []
        self.closed = False

    def on(self, topic: str, handler) -> None:
        self.handlers[topic] = handler

    def broadcast(self, topic: str, body) -> int:
        assert not self.closed
        self.sent.append((topic, body))
        return 1

    def close(self) -> None:
        self.closed = True

    def deliver(self, agent: int, message: dict) -> None:
        self.handlers[TOPIC](SimpleNamespace(topic=TOPIC, body={"agent": agent, "m": message}))


def _program(tmp_path: Path, role_count: int = 1) -> tuple[CaravanProgram, MavsdkVehicle, Radio]:
    world = {"kind": "taskmap", "seed": 1, "size_m": [10.0, 10.0], "grid_spacing_m": 1.0,
             "task_count": 1, "agent_count": 2}  # fmt: skip
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(world))
    params = full_stack_params(CaravanParams(speed_m_s=2.0), top_speed_m_s=12.0)
    env = ScenarioEnv(
        mavlink_url="swarm://",  # never connected: the vehicle and radio are fakes
        grpc_port=0,
        vehicle=1,
        vehicles=role_count,
        role="caravan",
        role_index=0,
        role_count=role_count,
        seed=0,
        out_dir=tmp_path,
        world=path,
        params=dataclasses.asdict(params),
    )
    vehicle = MavsdkVehicle(HOME)
    node = FakeNode()
    radio = Radio(node, TOPIC)
    return CaravanProgram(env, vehicle, radio), vehicle, radio


def test_full_stack_params_cap_the_speed_and_widen_the_arrival_only():
    """The autopilot's top speed caps the role's; the arrival tolerance is at least 1 m."""
    p = CaravanParams(speed_m_s=15.0, arrive_tolerance_m=0.25, release_timeout_s=2.0)
    q = full_stack_params(p, top_speed_m_s=12.0)
    assert (q.speed_m_s, q.arrive_tolerance_m) == (12.0, FULL_STACK_ARRIVE_M)
    assert dataclasses.replace(q, speed_m_s=15.0, arrive_tolerance_m=0.25) == p
    assert full_stack_params(CaravanParams(arrive_tolerance_m=2.0), 12.0).arrive_tolerance_m == 2.0


def test_radio_hands_over_every_message_once_across_decisions():
    """Messages that arrive between two polls are all handed over, once, at the next poll."""
    node = FakeNode()
    radio = Radio(node, TOPIC)
    for k in range(3):
        node.deliver(k, {"k": k})
        node.deliver(k + 10, {"k": k})
        got = radio.poll()
        assert [e.body["agent"] for e in got] == [k, k + 10]
        assert radio.poll() == []
    assert radio.heard == 6
    radio.close()
    assert node.closed and radio.broadcast(TOPIC, {}) == 0


def test_a_lone_vehicle_takes_off_flies_to_its_task_completes_it_and_lands_at_home(tmp_path):
    """Take-off to its height, the goto to its task once climbed, the task completed 0.8 m
    from it (within the full-stack tolerance), home, land, done; one message per decision."""
    program, vehicle, radio = _program(tmp_path)
    (task_xy,) = task_map(str(program.env.world))[0]
    program.decide(0.0)
    assert vehicle.take_commands() == [("takeoff", program.height_m)]
    assert program.allocator.task == 0 and not vehicle.path_done
    vehicle.see_armed(True)
    vehicle.see_position(*HOME[:2], 0.5 * program.height_m)
    program.decide(0.2)
    assert vehicle.take_commands() == [] and program.phase == "climb"
    vehicle.see_position(*HOME[:2], program.height_m)
    program.decide(0.4)  # climbed: the mission starts, the flight at the next decision
    assert program.phase == "mission" and program.mission_start_s == 0.4
    program.decide(0.6)
    ((kind, target),) = vehicle.take_commands()
    assert kind == "goto" and target == pytest.approx((*task_xy, program.height_m))
    vehicle.see_position(task_xy[0] + 0.8, task_xy[1], program.height_m)
    program.decide(0.8)
    assert program.allocator.stats.completed == [(0, 0.8)] and program.allocator.finished
    ((kind, target),) = vehicle.take_commands()[-1:]
    assert kind == "goto" and target == pytest.approx((*HOME[:2], program.height_m))
    assert program.phase == "home" and not vehicle.path_done
    vehicle.see_position(*HOME[:2], program.height_m)
    program.decide(1.0)
    assert vehicle.take_commands() == [("land",)] and program.phase == "land"
    vehicle.see_armed(False)
    program.decide(1.2)
    assert program.phase == "done" and program.done
    assert len(radio.node.sent) == 6  # one message per consensus step, none while landing
    metrics = program.metrics()
    assert metrics["completions"] == ([[0, 0.8]], "list")
    assert metrics["start_xy"] == ([-3.0, -3.0], "m")


def test_a_vehicle_disarmed_in_flight_is_down_and_stops_talking(tmp_path):
    """Disarmed after it was seen armed (flight termination): phase down, no command, no
    message; a stale 'disarmed' before the first 'armed' is no loss."""
    program, vehicle, radio = _program(tmp_path, role_count=2)
    program.decide(0.0)
    vehicle.take_commands()
    vehicle.see_armed(False)  # the heartbeat before the arming's
    program.decide(0.2)
    assert program.phase == "climb"
    vehicle.see_armed(True)
    vehicle.see_position(*HOME[:2], program.height_m)
    program.decide(0.4)
    program.decide(0.6)
    assert vehicle.take_commands()[0][0] == "goto"
    sent = len(radio.node.sent)
    vehicle.see_armed(False)
    program.decide(0.8)
    assert program.phase == "down" and program.done
    program.decide(1.0)
    assert vehicle.take_commands() == [] and len(radio.node.sent) == sent
    assert program.metrics()["phase"] == ("down", "name")


def test_the_shipped_scenario_crashes_one_of_four_vehicles_on_a_seven_task_map():
    """caravan_kill.yaml loads; its fleet, tasks and fault are what its checks count on."""
    scenario = load_scenario(scenario_path("caravan_kill"))
    spec = scenario.spec
    assert spec.n_vehicles == 4 and spec.fleet[0].node == "edge"
    assert tuple(spec.checks.metrics["fleet.run.tasks_validated"]) == (7, 7)
    (fault,) = spec.faults
    assert fault.vehicle == 2 and set(fault.kind) == {"crash", "radio"}
