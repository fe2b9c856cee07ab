"""The companion clock scales wall time by the simulation speed factor (1 on real hardware)."""

import asyncio
import time

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
    monkeypatch.setenv("SWARMSITL_SPEED", "10")
    t0 = clock.now_s()
    asyncio.run(clock.sleep(1.0))  # 0.1 s of wall time
    assert clock.now_s() - t0 >= 1.0 - 1e-6
    assert time.monotonic() * 10 - clock.now_s() < 1.0
