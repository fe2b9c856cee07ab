"""The clock file the harness publishes reads back as the time published."""

from __future__ import annotations

from harness.run.sim_clock import ClockFile, read_time_s


def test_a_published_time_reads_back(tmp_path):
    clock = ClockFile(tmp_path / "clock")
    try:
        assert read_time_s(clock.path) == 0.0
        clock.publish(12.345)
        assert read_time_s(clock.path) == 12.345
    finally:
        clock.close()
    assert read_time_s(clock.path) == 12.345  # the file keeps the last time
