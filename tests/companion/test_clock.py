"""The companion clock scales wall time by the simulation speed factor (1 on real hardware)."""

import asyncio

import pytest

from companion import clock


@pytest.mark.parametrize(("env", "factor"), [(None, 1.0), ("4", 4.0), ("0", 1.0), ("x", 1.0)])
def test_speed_factor_from_environment(monkeypatch, env, factor):
    if env is None:
        monkeypatch.delenv("SWARMSITL_SPEED", raising=False)
    else:
        monkeypatch.setenv("SWARMSITL_SPEED", env)
    assert clock.speed_factor() == factor


def test_sleep_is_in_simulated_seconds(monkeypatch):
    """clock.sleep(1 s) at 10x asks asyncio for 0.1 s of wall time."""
    monkeypatch.setenv("SWARMSITL_SPEED", "10")
    asked = []

    async def fake_sleep(seconds):
        asked.append(seconds)

    monkeypatch.setattr(clock.asyncio, "sleep", fake_sleep)
    asyncio.run(clock.sleep(1.0))
    assert asked == [pytest.approx(0.1)]


def test_now_is_scaled_monotonic_time(monkeypatch):
    monkeypatch.setenv("SWARMSITL_SPEED", "3")
    monkeypatch.setattr(clock.time, "monotonic", lambda: 100.0)
    assert clock.now_s() == pytest.approx(300.0)


def test_now_counts_from_the_simulation_origin(monkeypatch):
    """With SWARMSITL_CLOCK_ORIGIN the clock reads simulated time since the paced start."""
    monkeypatch.setenv("SWARMSITL_SPEED", "4")
    monkeypatch.setenv("SWARMSITL_CLOCK_ORIGIN", "90.0")
    monkeypatch.setattr(clock.time, "monotonic", lambda: 100.0)
    assert clock.now_s() == pytest.approx(40.0)
    monkeypatch.setenv("SWARMSITL_CLOCK_ORIGIN", "garbage")
    assert clock.now_s() == pytest.approx(400.0)


def test_clock_file_gives_the_simulation_time(monkeypatch, tmp_path):
    """An unpaced run publishes its time in SWARMSITL_CLOCK_FILE; now_s reads it, not wall time."""
    from harness.run.sim_clock import ClockFile

    clock_file = ClockFile(tmp_path / "clock")
    monkeypatch.setenv("SWARMSITL_CLOCK_FILE", str(clock_file.path))
    monkeypatch.setenv("SWARMSITL_SPEED", "3")
    try:
        clock_file.publish(12.5)
        assert clock.now_s() == 12.5
        clock_file.publish(13.0)
        assert clock.now_s() == 13.0
    finally:
        clock_file.close()


def test_sleep_on_the_clock_file_waits_for_simulated_time(monkeypatch, tmp_path):
    """clock.sleep(2) returns only once the published simulation time advanced by 2 s."""
    from harness.run.sim_clock import ClockFile

    clock_file = ClockFile(tmp_path / "clock")
    monkeypatch.setenv("SWARMSITL_CLOCK_FILE", str(clock_file.path))
    clock_file.publish(10.0)
    seen = []

    async def scenario():
        async def advance():
            for k in range(1, 31):
                await asyncio.sleep(0.002)
                seen.append(10.0 + 0.1 * k)
                clock_file.publish(10.0 + 0.1 * k)

        task = asyncio.create_task(advance())
        await clock.sleep(2.0)
        now = clock.now_s()
        await task
        return now

    try:
        woke_at = asyncio.run(scenario())
    finally:
        clock_file.close()
    assert woke_at >= 12.0 - 1e-9  # not before two simulated seconds passed (wall time: ~40 ms)
    assert max(seen) == pytest.approx(13.0)
