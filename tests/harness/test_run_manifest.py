"""The run manifest round-trips through manifest.json, and bad files fail with their reason."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from harness.run.manifest import (
    FORMAT_VERSION,
    MANIFEST_FILE,
    ManifestError,
    RunManifest,
    read_manifest,
    write_manifest,
)
from harness.sim.simulation import Simulation, SimulationConfig


def _manifest(**changes) -> RunManifest:
    fields = {
        "seed": 42,
        "n_vehicles": 3,
        "airframes": ("typhoon_h480", "typhoon_h480", "x500"),
        "roles": ("edge", "edge", "fog"),
        "world": "world.yaml",
        "spawn_enu_m": ((0.0, 0.0, 32.2), (5.0, 0.0, 32.2), (10.0, 0.0, 0.18)),
        "origin": (57.1, 1.9, 0.0),
        "physics_hz": 500.0,
        "record_hz": 20.0,
        "duration_s": 120.0,
    }
    fields.update(changes)
    return RunManifest(**fields)


def test_round_trip_keeps_every_field_and_leaves_no_temporary_file(tmp_path):
    start = _manifest()
    path = write_manifest(tmp_path, start)
    assert path == tmp_path / MANIFEST_FILE
    assert read_manifest(tmp_path) == start
    end = start.finished(sim_time_s=87.5, complete=False)
    write_manifest(tmp_path, end)  # replaces the start's
    back = read_manifest(tmp_path)
    assert back == end and back.sim_time_s == 87.5 and not back.complete
    assert back.started_utc == start.started_utc
    assert sorted(p.name for p in tmp_path.iterdir()) == [MANIFEST_FILE]
    data = json.loads(path.read_text())
    assert next(iter(data)) == "format_version" and data["format_version"] == FORMAT_VERSION


def test_unlimited_duration_and_no_world_round_trip(tmp_path):
    start = _manifest(duration_s=None, world=None, roles=("", "", ""))
    write_manifest(tmp_path, start)
    assert read_manifest(tmp_path) == start


def test_missing_manifest_says_so(tmp_path):
    with pytest.raises(ManifestError, match="no run manifest"):
        read_manifest(tmp_path)


def test_truncated_manifest_names_file_and_position(tmp_path):
    write_manifest(tmp_path, _manifest())
    path = tmp_path / MANIFEST_FILE
    path.write_text(path.read_text()[:200])
    with pytest.raises(ManifestError, match=r"manifest\.json:\d+:\d+: corrupt run manifest"):
        read_manifest(tmp_path)


def test_newer_format_asks_for_an_upgrade(tmp_path):
    write_manifest(tmp_path, _manifest())
    path = tmp_path / MANIFEST_FILE
    data = json.loads(path.read_text())
    data["format_version"] = FORMAT_VERSION + 1
    data["something_new"] = [1, 2]
    path.write_text(json.dumps(data))
    with pytest.raises(ManifestError, match=r"newer.*upgrade swarmsitl"):
        read_manifest(tmp_path)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"n_vehicles": 2}, "airframes: need one per vehicle"),
        ({"physics_hz": "fast"}, "physics_hz"),
        ({"spawn_enu_m": [[0, 0]] * 3}, "spawn_enu_m"),
        ({"origin": [95.0, 0.0, 0.0]}, "origin"),
        ({"complete": "yes"}, "complete"),
        ({"world": "../elsewhere.yaml"}, "world"),
        ({"started_utc": "yesterday"}, "started_utc"),
        ({"extra": 1}, "unknown field"),
    ],
)
def test_wrong_fields_are_named(tmp_path, change, message):
    data = _manifest().to_json()
    data.update(change)
    (tmp_path / MANIFEST_FILE).write_text(json.dumps(data))
    with pytest.raises(ManifestError, match=message):
        read_manifest(tmp_path)


def test_missing_field_is_named(tmp_path):
    data = _manifest().to_json()
    del data["seed"], data["started_utc"]
    (tmp_path / MANIFEST_FILE).write_text(json.dumps(data))
    with pytest.raises(ManifestError, match=r"missing field.*seed, started_utc"):
        read_manifest(tmp_path)


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"n_vehicles": 0}, "n_vehicles"),
        ({"roles": ("edge",)}, "roles"),
        ({"record_hz": -1.0}, "record_hz"),
        ({"duration_s": 0.0}, "duration_s"),
        ({"seed": 1.5}, "seed"),
    ],
)
def test_constructor_rejects_bad_values_naming_the_field(change, field):
    with pytest.raises(ValueError, match=field):
        _manifest(**change)


def test_from_simulation_records_the_spawn_poses_and_airframes():
    """The start manifest of a mixed fleet: spawn points 5 m apart along east, each resting on
    its own skids, and the world's origin."""
    config = SimulationConfig(
        n_vehicles=2, frames=("typhoon_h480", "x500"), mavlink=False, record_hz=0, seed=5
    )
    with Simulation(config) as sim:
        m = RunManifest.from_simulation(sim, 30.0, roles=("edge", "fog"))
        assert m.airframes == ("typhoon_h480", "x500") and m.seed == 5 and m.n_vehicles == 2
        spawn = np.array(m.spawn_enu_m)
        assert np.allclose(spawn[:, :2], [[0.0, 0.0], [5.0, 0.0]])
        clearance = [spec.ground_clearance_m for spec in sim.world.airframes]
        assert np.allclose(spawn[:, 2], clearance, atol=1e-3)
        assert m.origin == pytest.approx(
            (sim.world.origin.lat_deg, sim.world.origin.lon_deg, sim.world.origin.alt_amsl_m)
        )
        assert m.sim_time_s == 0.0 and not m.complete
        sim.run_lockstep(0.01)
        with pytest.raises(ValueError, match="before the first step"):
            RunManifest.from_simulation(sim, 30.0)


def test_finished_changes_only_time_and_completion():
    start = _manifest()
    end = start.finished(120.0, True)
    assert dataclasses.replace(end, sim_time_s=0.0, complete=False) == start
