"""Fixtures shared by the MAVLink endpoint tests."""

from __future__ import annotations

import pytest
from mavlink_fakes import FakeVehicle, MavClient, make_endpoint


@pytest.fixture
def client():
    """A pymavlink-speaking UDP client posing as MAVSDK (245/190)."""
    c = MavClient()
    yield c
    c.close()


@pytest.fixture
def vehicle():
    """A scripted VehiclePort."""
    return FakeVehicle()


@pytest.fixture
def endpoint(vehicle):
    """An endpoint on a free port, HEARTBEAT stream off so tests see only what they ask for."""
    with make_endpoint(vehicle, stream_rates_hz={"HEARTBEAT": 0}) as ep:
        yield ep
