"""The vehicle clock advances only with telemetry timestamps, never with the wall clock."""

import asyncio

import pytest

from companion.vehicle_clock import VehicleClock, VehicleClockError


def test_sleep_ends_when_the_vehicle_time_has_advanced():
    """A 2 s sleep returns after the stamp 2 s past the start, however fast stamps arrive."""

    async def scenario():
        vc = VehicleClock()
        vc.feed(10_000_000)
        sleeper = asyncio.create_task(vc.sleep(2.0, timeout_wall_s=5.0))
        await asyncio.sleep(0)  # the sleep starts now, at vehicle time 10 s
        for stamp in range(10_100_000, 11_900_001, 100_000):
            vc.feed(stamp)
            await asyncio.sleep(0)
        assert not sleeper.done()
        vc.feed(12_000_000)
        return await sleeper

    assert asyncio.run(scenario()) == pytest.approx(12.0)


def test_old_and_zero_stamps_are_ignored():
    vc = VehicleClock()
    assert not vc.started
    vc.feed(0)
    assert not vc.started
    vc.feed(5_000_000)
    vc.feed(4_000_000)
    assert vc.now_s == pytest.approx(5.0)


def test_a_silent_vehicle_times_out_on_the_wall_clock():
    """No telemetry: the wall-clock bound raises instead of hanging."""

    async def scenario():
        vc = VehicleClock()
        vc.feed(1_000_000)
        await vc.sleep(1.0, timeout_wall_s=0.05)

    with pytest.raises(VehicleClockError, match="vehicle time"):
        asyncio.run(scenario())


def test_follow_feeds_every_stamp():
    async def stamps():
        for s in (1_000_000, 2_000_000, 3_500_000):
            yield s

    async def scenario():
        vc = VehicleClock()
        await vc.follow(stamps())
        return vc.now_s

    assert asyncio.run(scenario()) == pytest.approx(3.5)
