"""The ACO swarm program's MAVSDK adapter without MAVSDK: what the swarm program decides, it does.

``AcoProgram`` (the decisions both adapters run) drives :class:`MavsdkVehicle` (telemetry in,
queued commands and velocity setpoints out) with the full stack's :class:`ObstacleSensor`; the
e2e run (tests/harness/test_aco_arena_e2e.py) flies them on the full stack.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from companion.scenario_env import ScenarioEnv
from companion.scripts.aco_swarm import (
    PAPER_DIAMETER_M,
    PEER_STALE_S,
    LocalFrame,
    MavsdkVehicle,
    ObstacleSensor,
    diameters,
    full_stack_params,
)
from companion.swarm.aco import TOPIC, AcoProgram, AcoRoleParams, Peer, arena
from worlds.solid_set import solid_distance

WORLD = {
    "kind": "arena_aco", "seed": 19, "size_m": [300, 120], "static_obstacle_count": 3,
    "static_obstacle_size_m": [8, 16], "obstacle_height_m": [30, 60], "moving_obstacle_count": 5,
    "moving_obstacle_diameter_m": [2, 4], "moving_obstacle_speed_m_s": [0.5, 1.5],
    "moving_obstacle_altitude_m": [13, 18], "zone_radius_m": 15,
}  # fmt: skip
ACC_M_S2 = 3.0
"""The plant's acceleration limit (PX4's MPC_ACC_HOR default), m/s^2."""


def _env(tmp_path: Path, args: dict, vehicle: int = 1, n: int = 1, **fleet_extra) -> ScenarioEnv:
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(WORLD))
    fleet = tuple(
        {"vehicle": k + 1, "role": "aco", "role_index": k, "priority": 10 + k} | fleet_extra
        for k in range(n)
    )
    return ScenarioEnv(
        mavlink_url="udpin://0.0.0.0:0", grpc_port=0, vehicle=vehicle, vehicles=n, role="aco",
        role_index=vehicle - 1, role_count=n, seed=3, out_dir=tmp_path, world=path,
        params=args, fleet=fleet,
    )  # fmt: skip


class FakeRadio:
    """What the program uses of a radio: ``poll`` and ``broadcast`` (kept for the test)."""

    def __init__(self) -> None:
        self.sent: list[tuple[str, dict]] = []
        self.inbox: list[SimpleNamespace] = []

    def poll(self) -> list[SimpleNamespace]:
        out, self.inbox = self.inbox, []
        return out

    def broadcast(self, topic: str, body: dict) -> int:
        self.sent.append((topic, body))
        return 1


def test_a_lone_vehicle_takes_off_waits_for_departure_flies_its_path_and_lands_at_target(
    tmp_path: Path,
) -> None:
    """Take-off to ``altitude_m``; climbed, it leaves only at ``depart_s``, in Offboard; a point
    mass following the velocity setpoints reaches the target, the program lands it there and
    ends when it is disarmed; the metrics say so, with its fleet entry's priority broadcast."""
    args = {"option": 1, "roadmap_nodes": 40, "iterations": 10, "altitude_band_m": 0,
            "depart_s": 12.0}  # fmt: skip
    env = _env(tmp_path, args)
    world = arena(str(env.world))
    start = next(a for a in world.launch_areas if a.name == "start")
    home = np.array(start.center_enu_m, float)
    sensor = ObstacleSensor(world, 1.2, {})
    vehicle = MavsdkVehicle(home, env.priority, sensor)
    radio = FakeRadio()
    program = AcoProgram(env, vehicle, radio)
    sensor.peers = program.peers
    assert vehicle.priority == 10
    dt, every = 0.02, 5
    pos, vel = home.copy(), np.zeros(3)
    commands: list[tuple] = []
    mode = "ground"
    offboard_at = None
    for k in range(round(150.0 / dt)):
        t = k * dt
        vehicle.see_position(pos)
        if k % every == 0:
            vehicle.see_time(t)
            program.decide(t)
            for c in vehicle.take_commands():
                commands.append(c)
                if c[0] == "takeoff":
                    vehicle.see_armed(True)
                    mode = "climb"
                elif c[0] == "offboard":
                    mode, offboard_at = "offboard", t
                elif c[0] == "land":
                    mode = "land"
            if program.done:
                break
        if mode == "climb":
            want = np.array([0.0, 0.0, 3.0 if pos[2] < 15.0 else 0.0])
        elif mode == "offboard":
            want = vehicle.setpoint()
        elif mode == "land":
            assert vehicle.setpoint() is None
            want = np.array([0.0, 0.0, -1.5])
            if pos[2] <= 0.0:
                vehicle.see_armed(False)
        else:
            want = np.zeros(3)
        dv = want - vel
        n = float(np.linalg.norm(dv))
        if n > ACC_M_S2 * dt:
            dv *= ACC_M_S2 * dt / n
        vel += dv
        pos += vel * dt
    assert [c[0] for c in commands] == ["takeoff", "offboard", "land"], commands
    assert commands[0] == ("takeoff", 15.0)
    assert offboard_at is not None and args["depart_s"] <= offboard_at < args["depart_s"] + 0.2
    assert program.phase == "done"
    m = {name: value for name, (value, _) in program.metrics().items()}
    assert m["reached"] and m["mission_start_s"] == pytest.approx(offboard_at)
    assert m["arrived_s"] > m["mission_start_s"] + m["min_dist_m"] / 6.0
    assert m["total_dist_m"] >= m["min_dist_m"] - 1.0
    topics = {topic for topic, _ in radio.sent}
    assert topics == {TOPIC} and all(body["prio"] == 10 for _, body in radio.sent)


def test_the_sensor_sees_the_world_solids_where_the_motion_law_puts_them(tmp_path: Path) -> None:
    """A drum 2 m from the vehicle's body at time t is sensed at 2 m clearance (the independent
    distance of ``worlds.solid_set.solid_distance`` less the body's radius), with its velocity;
    30 s later it has drifted away and is not."""
    world = arena(str(_env(tmp_path, {}).world))
    drum = next(s for s in world.solids if s.motion is not None)
    sensor = ObstacleSensor(world, 1.2, {})
    t = 40.0
    c = np.array(drum.center_at(t))
    here = c + np.array([drum.size_m[0] / 2.0 + 0.6 + 2.0, 0.0, 0.0])
    seen = {s.name: s for s in sensor.sense(here, t, 5.0)}
    expected = solid_distance(drum, here, t) - 0.6
    assert seen[drum.name].distance_m == pytest.approx(expected) and expected == pytest.approx(2.0)
    step = (np.array(drum.center_at(t + 1e-4)) - np.array(drum.center_at(t - 1e-4))) / 2e-4
    assert seen[drum.name].velocity_enu_m_s == pytest.approx(step, abs=1e-3)
    assert seen[drum.name].kind == "solid"
    assert solid_distance(drum, here, t + 30.0) - 0.6 > 5.0  # it drifted away meanwhile
    assert drum.name not in {s.name for s in sensor.sense(here, t + 30.0, 5.0)}


def test_the_sensor_sees_peers_where_their_messages_put_them_until_they_fall_silent(
    tmp_path: Path,
) -> None:
    """A peer heard at t0 is sensed at its extrapolated position, its clearance net of both
    bodies (its airframe's diameter from the fleet), nearest first; unheard for more than
    PEER_STALE_S it is not sensed."""
    world = arena(str(_env(tmp_path, {}).world))
    sensor = ObstacleSensor(world, 1.0, {1: 2.0})
    far = np.array([0.0, 0.0, 80.0])  # above every solid
    body = {"k": 1, "t": 10.0, "prio": 2, "s": [0, 0, 15], "p": [3.0, 0.0, 80.0], "v": [1, 0, 0]}
    near = dict(body, k=2, p=[0.0, 2.5, 80.0], v=[0, 0, 0])
    sensor.peers = {"n1": Peer.from_body(body), "n2": Peer.from_body(near)}
    seen = sensor.sense(far, 10.5, 5.0)
    assert [s.name for s in seen] == ["n2", "n1"]
    assert seen[1].position_enu_m == pytest.approx((3.5, 0.0, 80.0))
    assert seen[1].distance_m == pytest.approx(3.5 - 0.5 - 1.0)
    assert seen[0].distance_m == pytest.approx(2.5 - 0.5 - PAPER_DIAMETER_M / 2.0)
    assert all(s.kind == "vehicle" for s in seen)
    assert sensor.sense(far, 10.0 + PEER_STALE_S + 0.1, 5.0) == []


def test_diameters_and_priority_come_from_the_fleet_entries(tmp_path: Path) -> None:
    """Own and the role's diameters by role index; none given: the paper's 0.5 m."""
    env = _env(tmp_path, {}, vehicle=2, n=3, diameter_m=1.1)
    assert diameters(env) == (1.1, {0: 1.1, 1: 1.1, 2: 1.1}) and env.priority == 11
    bare = dataclasses.replace(env, fleet=None)
    assert diameters(bare) == (PAPER_DIAMETER_M, {}) and bare.priority == 2


def test_the_local_frame_puts_home_at_its_world_point_on_the_ground() -> None:
    """The local position at rest maps to the world (east, north) measured there, up 0; a metre
    north in NED is a metre north in ENU; velocities turn ENU -> NED."""
    frame = LocalFrame.at_rest((-120.0, 4.0), (0.3, -0.2, -0.1))
    assert frame.to_enu(np.array([0.3, -0.2, -0.1])) == pytest.approx([-120.0, 4.0, 0.0])
    assert frame.to_enu(np.array([1.3, -0.2, -5.1])) == pytest.approx([-120.0, 5.0, 5.0])
    assert LocalFrame.velocity_to_ned(np.array([1.0, 2.0, 3.0])) == pytest.approx([2, 1, -3])


def test_full_stack_params_cap_the_speed_only() -> None:
    p = AcoRoleParams(speed_m_s=15.0, option=2)
    q = full_stack_params(p, top_speed_m_s=12.0)
    assert q.speed_m_s == 12.0 and dataclasses.replace(q, speed_m_s=15.0) == p
    assert full_stack_params(AcoRoleParams(), 12.0).speed_m_s == 6.0


def test_the_vehicle_holds_a_velocity_until_it_flies_a_path_again() -> None:
    """A held velocity is streamed as it is, ``path_done`` is False meanwhile; the next path
    replaces it; Offboard is asked for once."""
    vehicle = MavsdkVehicle(np.zeros(3), 1, SimpleNamespace(sense=lambda *a: []))
    vehicle.see_position(np.array([0.0, 0.0, 15.0]))
    assert vehicle.setpoint() is None and not vehicle.offboard
    vehicle.fly_path(np.array([[0.0, 50.0, 15.0]]), 6.0)
    assert vehicle.setpoint() == pytest.approx([0.0, 6.0, 0.0])
    vehicle.set_velocity(np.zeros(3))
    assert vehicle.setpoint() == pytest.approx([0.0, 0.0, 0.0]) and not vehicle.path_done
    vehicle.fly_path(np.array([[0.0, 0.5, 15.0]]), 6.0)
    assert vehicle.path_done and math.isclose(vehicle.path_index, 0)
    assert vehicle.take_commands() == [("offboard",)]
    vehicle.land()
    assert vehicle.setpoint() is None and vehicle.take_commands() == [("land",)]
