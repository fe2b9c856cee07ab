"""What `swarmsitl run` tells a companion through SWARMSITL_* variables, read back exactly."""

import dataclasses
import json
from pathlib import Path

import pytest

from companion.scenario_env import ScenarioEnv, ScenarioEnvError


def full_env(tmp_path: Path) -> ScenarioEnv:
    return ScenarioEnv(
        mavlink_url="udpin://0.0.0.0:14541",  # port-literal: vehicle 2's default, not bound
        grpc_port=50052,  # port-literal: MAVSDK's default for vehicle 2, not bound
        vehicle=2,
        vehicles=3,
        role="survey",
        role_index=1,
        role_count=3,
        seed=7,
        out_dir=tmp_path / "vehicle2",
        world=tmp_path / "world.yaml",
        origin=(47.397742, 8.545594, 488.0),
        video_uri="http://127.0.0.1:5601/video.mjpg",  # port-literal: a default, not bound
        duration_s=120.0,
        params={"altitude_m": 30, "area": [[0, 0], [10, 0], [10, 10]]},
        fleet=tuple(
            {
                "vehicle": k + 1,
                "role": "survey",
                "role_index": k,
                "airframe": "typhoon_h480",
                "battery_capacity_mah": 5400.0 - 1000.0 * k,
                "traits": {"decision": 0.5 * k, "flight_time_s": 900.0},
            }
            for k in range(3)
        ),
    )


def test_round_trip_through_the_environment(tmp_path):
    env = full_env(tmp_path)
    variables = env.to_env()
    assert all(k.startswith("SWARMSITL_") and isinstance(v, str) for k, v in variables.items())
    assert ScenarioEnv.from_env(variables) == env


def test_pymavlink_url_is_the_same_port(tmp_path):
    url = "udpin:0.0.0.0:14541"  # port-literal: vehicle 2's default, not bound
    assert full_env(tmp_path).pymavlink_url == url


def test_optional_fields_absent(tmp_path):
    env = ScenarioEnv.from_env(
        {
            "SWARMSITL_MAVLINK_URL": "udpin://0.0.0.0:14540",  # port-literal: PX4's default
            "SWARMSITL_VEHICLE": "1",
        }
    )
    assert (env.world, env.origin, env.video_uri, env.params, env.duration_s, env.fleet) == (
        None,
    ) * 6
    assert env.grpc_port == 50051  # port-literal: 50050 + sysid, MAVSDK's default for vehicle 1


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("VEHICLE", "two"),
        ("ORIGIN", "47.3,8.5"),
        ("PARAMS", "{not json"),
        ("PARAMS", "[1, 2]"),
        ("FLEET", "[{not json"),
        ("FLEET", '{"vehicle": 1}'),
        ("FLEET", "[1, 2]"),
    ],
)
def test_malformed_variable_is_named(tmp_path, name, value):
    variables = full_env(tmp_path).to_env() | {f"SWARMSITL_{name}": value}
    with pytest.raises(ScenarioEnvError, match=f"SWARMSITL_{name}"):
        ScenarioEnv.from_env(variables)


def test_missing_url_says_how_to_start_the_program():
    with pytest.raises(ScenarioEnvError, match=r"SWARMSITL_MAVLINK_URL.*swarmsitl run"):
        ScenarioEnv.from_env({"SWARMSITL_VEHICLE": "1"})


def test_write_result_is_the_report_format(tmp_path):
    env = full_env(tmp_path)
    path = env.write_result({"spills_seen": (4, "count"), "distance_flown_m": (812.5, "m")})
    assert path == tmp_path / "vehicle2" / "result.json"
    assert json.loads(path.read_text()) == {
        "spills_seen": {"value": 4, "unit": "count"},
        "distance_flown_m": {"value": 812.5, "unit": "m"},
    }


def test_priority_is_the_fleet_entrys_else_the_vehicle_number(tmp_path):
    """The own fleet entry's ``priority`` when given; the vehicle number without one, or
    without a fleet (a companion started by hand)."""
    env = full_env(tmp_path)
    assert env.fleet_entry == env.fleet[1] and env.priority == 2
    fleet = tuple(dict(e, priority=10 - e["vehicle"]) for e in env.fleet)
    assert dataclasses.replace(env, fleet=fleet).priority == 8
    assert dataclasses.replace(env, fleet=None).fleet_entry is None
    assert dataclasses.replace(env, vehicle=3, fleet=None).priority == 3
