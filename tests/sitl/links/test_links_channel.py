"""One direction of a link: delay distribution, drop-tail queue, serialisation, outages."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from sitl.links.channel import DatagramTooLargeError, DeliveryQueue, Drop, LinkChannel
from sitl.links.config import LinksConfig
from sitl.links.network import mavlink_channels
from sitl.links.params import LatencyParams, LinkParams, LossParams, OutageParams


def _light_latencies(params: LinkParams, n: int, seed: int = 7) -> np.ndarray:
    """Delays after transmission of n datagrams spaced far apart (no queueing)."""
    channel = LinkChannel(params, np.random.default_rng(seed))
    gap_s = 10.0 * params.transmit_s(100) + 1e-3
    out = np.empty(n)
    for k in range(n):
        now = k * gap_s
        arrival, drop = channel.submit(now, 100)
        assert drop is None
        out[k] = arrival - now - params.transmit_s(100)
    return out


@pytest.mark.parametrize(
    "latency",
    [
        LatencyParams(base_s=0.015, jitter="lognormal", jitter_s=0.006, sigma=0.6),
        LatencyParams(base_s=0.001, jitter="exponential", jitter_s=0.001),
        LatencyParams(base_s=0.002, jitter="gamma", jitter_s=0.004, shape=3.0),
    ],
    ids=["lognormal", "exponential", "gamma"],
)
def test_latency_of_a_lightly_loaded_link_follows_the_configured_distribution(latency):
    """20,000 delays pass a KS test (p > 0.01) against the configured distribution."""
    params = LinkParams(kind="test", rate_bps=1e8, latency=latency)
    delays = _light_latencies(params, 20_000)
    assert stats.kstest(delays, latency.distribution().cdf).pvalue > 0.01
    # and the test has teeth: a 10 % larger median fails it
    wrong = LatencyParams(
        base_s=latency.base_s,
        jitter=latency.jitter,
        jitter_s=latency.jitter_s * 1.1,
        sigma=latency.sigma,
        shape=latency.shape,
    )
    assert stats.kstest(delays, wrong.distribution().cdf).pvalue < 0.01


def test_shipped_lte_uplink_delays_match_its_distribution():
    """The LTE preset's uplink delay (the number users see) passes the KS test."""
    up, _down = LinksConfig.load().link("lte")
    no_loss = LinkParams(**{**up.__dict__, "loss": LossParams()})
    delays = _light_latencies(no_loss, 20_000, seed=3)
    assert stats.kstest(delays, up.latency.distribution().cdf).pvalue > 0.01


def test_one_megabyte_over_the_lte_uplink_takes_its_physical_time():
    """1 MB in 1400-B datagrams arrives in bytes x 8 / 50 Mbps + latency, within 5 %."""
    config = LinksConfig.from_dict(
        {"presets": {"lte": {"loss": {"mean_loss": 0.0}, "queue_bytes": 2_000_000}}}
    )
    up, _ = config.link("lte")
    channel = LinkChannel(up, np.random.default_rng(11))
    total = 1_000_000
    sizes = [1400] * (total // 1400) + [total % 1400]
    arrivals = []
    for size in sizes:
        arrival, drop = channel.submit(0.0, size)
        assert drop is None
        arrivals.append(arrival)
    # the last datagram sent arrives one mean latency after 1 MB at 50 Mbps (IP/UDP headers
    # add 2 %); the whole megabyte is in before the 99th percentile of the delay
    expected_s = total * 8 / 50e6 + up.latency.mean_s
    assert arrivals[-1] == pytest.approx(expected_s, rel=0.05)
    wire_s = sum(up.transmit_s(size) for size in sizes)
    assert wire_s < max(arrivals) <= wire_s + up.latency.distribution().ppf(0.99)


def test_drop_tail_queue_fills_drops_and_bounds_the_delay():
    """Above the rate the queue fills and drops; below it nothing drops; delay grows with load."""
    params = LinkParams(
        kind="serial", rate_bps=921600, bits_per_byte=10, overhead_bytes=0, queue_bytes=4096,
        max_datagram_bytes=280,
    )  # fmt: skip
    bytes_per_s = 92160.0
    mean_delay = {}
    for load in (0.3, 0.7, 0.9, 2.0):
        channel = LinkChannel(params, np.random.default_rng(5))
        rng = np.random.default_rng(9)
        t = 0.0
        gaps = rng.exponential(100 / bytes_per_s / load, 20_000)  # Poisson arrivals of 100 B
        for gap in gaps:
            t += gap
            channel.submit(t, 100)
        s = channel.stats
        lat = np.asarray(s.latencies_s)
        mean_delay[load] = lat.mean()
        # no datagram waits longer than a full queue takes to drain (plus its own transmission)
        assert lat.max() <= params.queue_bytes / bytes_per_s + params.transmit_s(100) + 1e-9
        if load < 1.0:  # a 41-datagram buffer overflows rarely below the rate
            assert s.dropped.get("queue", 0) < 0.002 * s.submitted
        else:
            assert s.dropped["queue"] > 0.4 * s.submitted  # half the offered load is too much
            assert s.delivered + s.dropped["queue"] == s.submitted
    assert mean_delay[0.3] < mean_delay[0.7] < mean_delay[0.9] < mean_delay[2.0]
    # M/D/1 mean wait at load 0.7: rho / (2 mu (1 - rho)); plus the service time
    service = 100 / bytes_per_s
    md1 = 0.7 * service / (2 * (1 - 0.7)) + service
    assert mean_delay[0.7] == pytest.approx(md1, rel=0.1)


def test_uart_at_921600_baud_carries_92160_bytes_per_second():
    """A saturated 921600-baud 8N1 UART delivers 92160 B/s of MAVLink frames."""
    to_vehicle, _ = mavlink_channels("uart", None, seed=0, vehicle_index=0)
    duration_s = 5.0
    frame = 280
    period = frame / (2 * 92160.0)  # offered at twice the line rate
    delivered = 0
    for k in range(int(duration_s / period)):
        arrival, _ = to_vehicle.submit(k * period, frame)
        if arrival is not None and arrival <= duration_s:
            delivered += frame
    assert delivered / duration_s == pytest.approx(92160.0, rel=0.01)


def test_outage_windows_drop_everything_inside_them():
    """Datagrams submitted in a down window are dropped as DOWN; outside they all arrive."""
    params = LinkParams(outages=OutageParams(windows_s=((1.0, 2.0), (3.5, 3.75))))
    channel = LinkChannel(params, np.random.default_rng(1))
    for k in range(5000):
        t = k * 1e-3
        arrival, drop = channel.submit(t, 100)
        down = 1.0 <= t < 2.0 or 3.5 <= t < 3.75
        assert (drop is Drop.DOWN) == down
        assert (arrival is None) == down
    assert channel.uptime_fraction(5.0) == pytest.approx(1 - 1.25 / 5.0)


def test_random_outages_give_the_renewal_uptime():
    """Random failures (MTBF 20 s, MTTR 5 s) leave the link up 80 % of the time, measured."""
    params = LinkParams(outages=OutageParams(mtbf_s=20.0, mttr_s=5.0))
    channel = LinkChannel(params, np.random.default_rng(2))
    duration_s = 20_000.0
    ups = [channel.is_up(t) for t in np.arange(0.0, duration_s, 0.5)]
    measured = channel.uptime_fraction(duration_s)
    assert np.mean(ups) == pytest.approx(measured, abs=0.005)
    assert measured == pytest.approx(0.8, abs=0.02)


def test_oversized_datagram_is_refused():
    """A datagram above max_datagram_bytes raises, naming the limit (never truncated)."""
    to_vehicle, _ = mavlink_channels("uart", None, seed=0, vehicle_index=0)
    with pytest.raises(DatagramTooLargeError, match="280 B"):
        to_vehicle.submit(0.0, 281)
    assert to_vehicle.stats.submitted == 0


@given(
    st.lists(st.tuples(st.booleans(), st.sampled_from([0.0, 0.5, 1.0, 1.5, 2.0, 3.0])), max_size=60)
)
def test_delivery_queue_releases_by_arrival_then_submission(ops):
    """Whatever the order of pushes and polls (ties and late arrivals included), each poll
    releases exactly the items due, earliest first, ties in order of submission."""
    queue = DeliveryQueue()
    pending: list[tuple[float, int]] = []
    now_s = 0.0
    for k, (is_poll, t_s) in enumerate(ops):
        if is_poll:
            now_s = max(now_s, t_s)
            due = sorted(p for p in pending if p[0] <= now_s)
            pending = [p for p in pending if p[0] > now_s]
            assert queue.pop_due(now_s) == [index for _, index in due]
        else:
            queue.push(t_s, k)
            pending.append((t_s, k))
        assert len(queue) == len(pending)
        assert queue.next_arrival_s == min((p[0] for p in pending), default=math.inf)
    assert queue.clear() == [index for _, index in sorted(pending)]
    assert len(queue) == 0
