"""MavlinkLinkShaper: a MAVLink endpoint's traffic through two link channels, in sim time."""

from __future__ import annotations

import numpy as np
import pytest

from harness.run.ports import free_port_block
from sitl.links.channel import LinkChannel
from sitl.links.params import LinkParams, LossParams
from sitl.links.shaper import OVERSIZE, MavlinkLinkShaper

pytestmark = pytest.mark.sockets

BAUD = 921_600
UART_BYTES_PER_S = BAUD / 10
"""8N1: a start bit, 8 data bits and a stop bit per byte."""


def uart(queue_bytes: int = 3000, **changes: object) -> LinkParams:
    return LinkParams(
        kind="uart",
        rate_bps=BAUD,
        bits_per_byte=10,
        overhead_bytes=0,
        queue_bytes=queue_bytes,
        max_datagram_bytes=queue_bytes,
        in_order=True,
        **changes,
    )


def shaper(params: LinkParams, seed: int = 1) -> MavlinkLinkShaper:
    rngs = np.random.default_rng(seed).spawn(2)
    return MavlinkLinkShaper(LinkChannel(params, rngs[0]), LinkChannel(params, rngs[1]))


def frame(k: int, size: int = 280) -> bytes:
    return k.to_bytes(4, "little") * (size // 4)


def test_a_frame_arrives_after_its_bytes_crossed_the_uart():
    """One 100-byte frame on an idle UART arrives 100 x 10 bits / 921600 baud later."""
    s = shaper(uart())
    s.outbound(1.0, bytes(100))
    expected = 1.0 + 100 * 10 / BAUD
    assert s.next_due_s == pytest.approx(expected)
    assert s.due_outbound(expected - 1e-6) == []
    assert s.due_outbound(expected) == [bytes(100)]
    assert s.next_due_s == float("inf")


def test_uart_throughput_is_the_mavlink_budget_and_the_excess_is_dropped():
    """Frames offered at 3x 92160 B/s: delivered throughput is 92160 B/s, the rest dropped."""
    s = shaper(uart())
    step_s = 0.001
    size = 280
    per_step = 1  # 280 B per ms = 280 kB/s offered
    delivered: list[bytes] = []
    sent = 0
    t_first = None
    t_last = None
    for k in range(2000):
        now = k * step_s
        for _ in range(per_step):
            s.outbound(now, frame(sent, size))
            sent += 1
        due = s.due_outbound(now)
        if due:
            t_first = now if t_first is None else t_first
            t_last = now
        delivered += due
    stats = s.stats.from_vehicle
    # Steady state: the link is always busy, so bytes delivered between the first and last
    # delivery equal the budget over that time (within one frame and one poll step).
    window_s = t_last - t_first
    rate = (len(delivered) - 1) * size / window_s
    assert rate == pytest.approx(UART_BYTES_PER_S, rel=0.01)
    assert stats.dropped.get("queue", 0) > 0.5 * sent
    assert stats.frames == sent
    assert stats.delivered + stats.held + stats.dropped_total == sent
    # in order: frame numbers increase
    numbers = [int.from_bytes(f[:4], "little") for f in delivered]
    assert numbers == sorted(numbers)


def test_below_the_budget_nothing_is_dropped_and_delay_stays_short():
    """At half the budget every frame arrives, each within its own transmission time + a bit."""
    s = shaper(uart())
    size = 92  # 92 B every 2 ms = 46 kB/s
    for k in range(500):
        now = k * 0.002
        s.outbound(now, frame(k, size))
        assert len(s.due_outbound(now + 0.002 - 1e-9)) <= 1
    stats = s.stats.from_vehicle
    assert stats.dropped == {}
    assert stats.delivered + stats.held == 500


def test_inbound_datagrams_keep_their_sender():
    """A datagram from (host, port) comes out with that address, after its bytes crossed."""
    s = shaper(uart())
    sender = ("127.0.0.1", free_port_block())  # nothing binds it: any port of ours will do
    s.inbound(0.0, b"abc", sender)
    assert s.due_inbound(1.0) == [(b"abc", sender)]
    assert s.stats.to_vehicle.delivered == 1


def test_an_oversize_datagram_is_dropped_and_counted():
    """A datagram above max_datagram_bytes is refused (never truncated) and counted."""
    s = shaper(uart(queue_bytes=512))
    s.inbound(0.0, bytes(513), ("127.0.0.1", 1))
    s.inbound(0.0, bytes(10), ("127.0.0.1", 1))
    assert [d for d, _ in s.due_inbound(1.0)] == [bytes(10)]
    assert s.stats.to_vehicle.dropped == {OVERSIZE: 1}


def test_same_seed_same_drops():
    """A lossy link with the same seed drops the same frames."""
    params = uart(loss=LossParams(mean_loss=0.2))

    def run(seed: int) -> list[bytes]:
        s = shaper(params, seed)
        for k in range(300):
            s.outbound(k * 0.01, frame(k, 40))
        return s.due_outbound(10.0)

    a, b, c = run(7), run(7), run(8)
    assert a == b
    assert a != c
    assert 0.6 * 300 < len(a) < 0.95 * 300


def test_time_going_back_discards_what_was_in_flight():
    """A restarted simulation (time back to 0) starts with an empty link."""
    s = shaper(uart())
    s.outbound(5.0, bytes(1000))
    s.outbound(0.0, bytes(10))
    assert s.due_outbound(1.0) == [bytes(10)]
