"""FlightLog reads a run directory back: truth per vehicle, the autopilots' events in sim time."""

import math
import socket

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink2
from synthetic_run import (
    EPOCH_S,
    TlogWriter,
    command_ack,
    heartbeat,
    statustext,
    two_vehicle_run,
    vehicle_tlog,
)

from harness.report.flight_log import FlightLog

pytestmark = pytest.mark.sockets

TEXTS = [
    (0, 4.0, 6, "Armed by external command"),
    (0, 30.25, 2, "Failsafe activated: switching to Land"),
    (1, 12.5, 4, "Low battery level, return advised"),
]


@pytest.fixture
def run(tmp_path):
    tracks = two_vehicle_run(tmp_path / "run", texts=TEXTS)
    return tmp_path / "run", tracks


def test_truth_is_split_per_vehicle_in_time_order(run):
    run_dir, tracks = run
    log = FlightLog.load(run_dir)
    assert [v.name for v in log.vehicles] == ["vehicle1", "vehicle2"]
    assert log.warnings == []
    for v, tr in zip(log.vehicles, tracks, strict=True):
        assert len(v.track) == len(tr["time_s"])
        assert np.all(np.diff(v.track.time_s) > 0)
        np.testing.assert_allclose(v.track.enu_m[:, 0], tr["east_m"], atol=1e-4)
        np.testing.assert_allclose(v.track["up_m"], tr["up_m"], atol=1e-4)
    assert log.end_s == pytest.approx(50.0)


def test_status_texts_heartbeat_changes_and_acks_in_simulation_time(tmp_path, run):
    run_dir, tracks = run
    acks = [(3.5, mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, mavlink2.MAV_RESULT_DENIED)]
    vehicle_tlog(run_dir / "vehicle1.tlog", 1, tracks[0], [t[1:] for t in TEXTS[:2]], acks)
    log = FlightLog.load(run_dir)
    v1, v2 = log.vehicles
    assert [(s.time_s, s.severity, s.text) for s in v1.status_texts] == [t[1:] for t in TEXTS[:2]]
    assert [(s.time_s, s.text) for s in v2.status_texts] == [(12.5, TEXTS[2][3])]
    (ack,) = v1.command_acks
    assert (ack.time_s, ack.command_name, ack.result_name) == (
        3.5,
        "MAV_CMD_COMPONENT_ARM_DISARM",
        "MAV_RESULT_DENIED",
    )
    # Armed 1 s before lift-off (5 s + climb to 0.3 m) until 1 s after touchdown: at 1 Hz the
    # heartbeats show disarmed -> armed at 4 s (TAKEOFF not reached: mode unchanged), then off.
    changes = [(c.time_s, c.armed) for c in v1.state_changes]
    assert changes == [(0.0, False), (5.0, True), (46.0, False)]
    assert {c.mode for c in v1.state_changes} == {"LOITER"}
    # The companion's HEARTBEATs (system 245, disarmed, mode 0) made no state change.
    assert [(c.time_s, c.armed) for c in v2.state_changes] == changes


def test_wall_clock_stamps_are_mapped_to_simulation_time(run):
    """A ground station stamps with the wall clock; here the run went at 2x, 100 s late."""
    run_dir, tracks = run
    vehicle_tlog(
        run_dir / "vehicle1.tlog",
        1,
        tracks[0],
        [(30.25, 2, "Geofence violation")],
        stamp_of=lambda t: EPOCH_S + 100.0 + 0.5 * t,
    )
    (text,) = FlightLog.load(run_dir).vehicle(0).status_texts
    assert text.time_s == pytest.approx(30.25, abs=1e-5)


def test_a_truncated_tlog_reads_up_to_the_cut(run):
    run_dir, _ = run
    path = run_dir / "vehicle1.tlog"
    data = path.read_bytes()
    whole = FlightLog.load(run_dir).vehicle(0)
    # Cut inside the last frame, inside a stamp, in the middle of the file, at the start.
    for cut in (len(data) - 5, len(data) - 30, len(data) // 2 + 3, 4, 0):
        path.write_bytes(data[:cut])
        log = FlightLog.load(run_dir)
        texts = log.vehicle(0).status_texts
        assert texts == whole.status_texts[: len(texts)]
        if cut:
            assert any("vehicle1.tlog" in w and "no whole record" in w for w in log.warnings)
    path.write_bytes(data[: len(data) // 2])
    half = FlightLog.load(run_dir).vehicle(0)
    assert half.state_changes[0] == whole.state_changes[0]
    assert half.status_texts == [s for s in whole.status_texts if s.time_s < 25.0]


def test_garbage_in_a_tlog_is_skipped_and_reading_goes_on(run):
    run_dir, _ = run
    path = run_dir / "vehicle1.tlog"
    data = path.read_bytes()
    whole = FlightLog.load(run_dir).vehicle(0)
    path.write_bytes(data[:1000] + bytes(range(256)) * 4 + data[1000:])
    log = FlightLog.load(run_dir)
    assert any("vehicle1.tlog" in w and "corrupt" in w for w in log.warnings)
    v = log.vehicle(0)
    assert v.status_texts == whole.status_texts  # both after the garbage
    assert v.state_changes[-1] == whole.state_changes[-1]


def test_a_truncated_truth_file_reads_the_whole_lines(run):
    run_dir, _ = run
    path = run_dir / "truth.csv"
    text = path.read_text()
    path.write_text(text[: len(text) // 2 + 7])
    log = FlightLog.load(run_dir)
    assert any("truth.csv" in w and "cut short" in w for w in log.warnings)
    n = sum(len(v.track) for v in log.vehicles)
    assert n == text[: len(text) // 2 + 7].count("\n") - 1
    assert log.end_s < 30.0


def test_a_bad_line_in_truth_is_skipped_and_named(run):
    run_dir, _ = run
    path = run_dir / "truth.csv"
    lines = path.read_text().splitlines(keepends=True)
    lines[10] = "0.45,0,oops\n"
    path.write_text("".join(lines))
    log = FlightLog.load(run_dir)
    assert any("line 11" in w for w in log.warnings)
    assert sum(len(v.track) for v in log.vehicles) == len(lines) - 2


def test_missing_files_are_named(tmp_path, run):
    run_dir, _ = run
    with pytest.raises(FileNotFoundError, match="nowhere"):
        FlightLog.load(tmp_path / "nowhere")
    (run_dir / "vehicle2.tlog").unlink()
    with pytest.raises(FileNotFoundError, match=r"vehicle2\.tlog"):
        FlightLog.load(run_dir)
    log = FlightLog.load(run_dir, require_tlogs=False)
    assert any("vehicle2.tlog missing" in w for w in log.warnings)
    (run_dir / "truth.csv").unlink()
    with pytest.raises(FileNotFoundError, match=r"truth\.csv"):
        FlightLog.load(run_dir)


def test_unknown_vehicle_index_says_how_many_there_are(run):
    with pytest.raises(IndexError, match="2 vehicle"):
        FlightLog.load(run[0]).vehicle(2)


def test_a_long_text_in_chunks_reads_as_one(run):
    """The emulator's own chunking (STATUSTEXT id/chunk_seq) for a text of 120 bytes."""
    from autopilot_emu.mavlink.messages import statustext_chunks

    run_dir, tracks = run
    text = "Mission rejected: " + "waypoint beyond the geofence, " * 3 + "fix the plan"
    assert len(text) > 100
    path = run_dir / "vehicle1.tlog"
    vehicle_tlog(path, 1, tracks[0], [(9.0, 6, "before")])
    log = TlogWriter(path)
    log.records = []
    data = path.read_bytes()
    for k, msg in enumerate(statustext_chunks(4, text, chunk_id=7)):
        log.add(9.5 + 0.001 * k, msg, 1)
    log.close()
    path.write_bytes(data + path.read_bytes())
    texts = FlightLog.load(run_dir).vehicle(0).status_texts
    assert [(s.time_s, s.severity, s.text) for s in texts] == [(9.0, 6, "before"), (9.5, 4, text)]


def test_tlog_without_timed_messages_falls_back_to_its_own_stamps(run):
    run_dir, _ = run
    log = TlogWriter(run_dir / "vehicle1.tlog")
    log.add(2.0, heartbeat(False, 4, 3), 1)
    log.add(7.5, statustext(6, "hello"), 1)
    log.add(8.0, command_ack(400, 0), 1)
    log.close()
    fl = FlightLog.load(run_dir)
    assert [s.time_s for s in fl.vehicle(0).status_texts] == [5.5]
    assert any("no SYSTEM_TIME" in w for w in fl.warnings)


def test_a_real_lockstep_run_reads_back(tmp_path):
    """The simulator's own recorder and tlog writer: the events line up with the truth."""
    from harness.sim.simulation import PortPlan, Simulation, SimulationConfig

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sink:
        sink.bind(("127.0.0.1", 0))
        ports = PortPlan(listen_base=0, sdk_base=sink.getsockname()[1], gcs_port=0, payload_base=0)
        config = SimulationConfig(n_vehicles=1, ports=ports, out_dir=tmp_path, seed=3)
        with Simulation(config) as sim:
            v = sim.fleet.vehicle(0)
            sim.run_lockstep(3.0)
            assert v.arm(False) == 0
            assert v.takeoff(None) == 0
            sim.run_lockstep(9.0)
            assert v.land() == 0
            sim.run_lockstep(30.0, until=lambda s: not s.fleet.commanders[0].armed)
            sim.run_lockstep(1.5)
    log = FlightLog.load(tmp_path)
    assert log.warnings == []
    (veh,) = log.vehicles
    texts = {s.text: s.time_s for s in veh.status_texts}
    tr = veh.track
    armed_at = tr.time_s[np.argmax(tr["armed"] > 0.5)]
    disarmed_at = tr.time_s[np.flatnonzero(tr["armed"] > 0.5)[-1] + 1]
    # The recorder samples at 20 Hz: each text lies within one sample of the truth's change.
    assert texts["Armed by external command"] == pytest.approx(armed_at, abs=0.051)
    assert texts["Disarmed by landing"] == pytest.approx(disarmed_at, abs=0.051)
    armed_changes = [c for c in veh.state_changes if c.armed]
    assert armed_changes and math.ceil(armed_at) <= armed_changes[0].time_s <= armed_at + 1.01
    assert veh.state_changes[-1].armed is False
