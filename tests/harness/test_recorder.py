"""truth.csv is streamed while the run goes, so a process killed outright still leaves it."""

import csv

from harness.sim.recorder import COLUMNS, STREAM_EVERY_S
from harness.sim.simulation import Simulation, SimulationConfig


def read(path):
    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_truth_is_on_disk_before_close_and_complete_after(tmp_path):
    sim = Simulation(SimulationConfig(n_vehicles=2, mavlink=False, out_dir=tmp_path))
    try:
        sim.run_lockstep(2.5 * STREAM_EVERY_S)
        rows = read(tmp_path / "truth.csv")  # as a reader sees it before the run ends
        assert rows, "nothing streamed"
        times = sorted({float(r["time_s"]) for r in rows})
        assert STREAM_EVERY_S - 0.1 <= times[-1] <= 2 * STREAM_EVERY_S + 0.1
    finally:
        sim.close()
    rows = read(tmp_path / "truth.csv")
    assert list(rows[0]) == list(COLUMNS)
    times = [float(r["time_s"]) for r in rows if r["vehicle"] == "0"]
    assert times == sorted(times) and len(set(times)) == len(times)  # no sample written twice
    assert times[-1] >= 2.5 * STREAM_EVERY_S - 0.1
    walls = {float(r["wall_s"]) for r in rows}
    assert len(walls) > 1  # wall time kept to microseconds, not 6 significant digits
