"""The network of roles: class presets reproduce seed 000's loss, seeding, range, coverage."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from sitl.links.channel import DatagramTooLargeError, Drop
from sitl.links.config import LinksConfig
from sitl.links.network import LinkNetwork, mavlink_channels

SEED_000_LOSS = {"edge-edge": 0.0125, "edge-fog": 0.0075, "fog-fog": 0.0075, "fog-cloud": 0.0199}
"""Seed 000, indoor packet loss per link class (Fig. 30)."""


def _pair_network(class_name: str, seed: int, config: LinksConfig | None = None) -> LinkNetwork:
    a, b = class_name.split("-")
    network = LinkNetwork(config or LinksConfig.load(), seed)
    network.add_node("a", a)
    network.add_node("b", b)
    return network


def _losses(network: LinkNetwork, n: int, src: str = "a", dst: str = "b") -> np.ndarray:
    lost = np.empty(n, dtype=bool)
    for k in range(n):
        arrival, drop = network.submit(k * 1e-3, src, dst, 200)
        assert drop in (None, Drop.LOSS)
        lost[k] = arrival is None
    return lost


@pytest.mark.parametrize("class_name", ["edge-edge", "edge-fog"])
def test_bernoulli_class_loss_within_the_binomial_interval(class_name):
    """Measured loss of a Bernoulli class preset: its Clopper-Pearson 99 % interval holds
    seed 000's figure (200,000 datagrams)."""
    config = LinksConfig.load()
    assert config.class_preset(class_name).up.loss.model == "bernoulli"
    lost = _losses(_pair_network(class_name, seed=1), 200_000)
    ci = stats.binomtest(int(lost.sum()), lost.size).proportion_ci(0.99, method="exact")
    assert ci.low <= SEED_000_LOSS[class_name] <= ci.high
    assert ci.high - ci.low < 0.2 * SEED_000_LOSS[class_name]  # tight enough to mean something


@pytest.mark.parametrize("class_name", ["fog-fog", "fog-cloud"])
def test_gilbert_elliott_class_loss_within_a_batch_means_interval(class_name):
    """Bursty (Gilbert-Elliott) loss: the 99 % batch-means interval (50 batches of 8,000
    datagrams, much longer than a burst) holds seed 000's figure; the losses are bursty."""
    config = LinksConfig.load()
    assert config.class_preset(class_name).up.loss.model == "gilbert_elliott"
    lost = _losses(_pair_network(class_name, seed=2), 400_000)
    batches = lost.reshape(50, -1).mean(axis=1)
    half = stats.t.ppf(0.995, batches.size - 1) * batches.std(ddof=1) / np.sqrt(batches.size)
    assert abs(batches.mean() - SEED_000_LOSS[class_name]) <= half
    # bursts: a loss follows a loss far more often than the mean loss rate
    after_loss = lost[1:][lost[:-1]].mean()
    assert after_loss > 0.3


def test_records_report_seed_000_metrics():
    """records(): loss and availability as seed 000 (availability = 100 - loss), throughput,
    latency percentiles, per class and per direction; airtime per node adds up."""
    network = LinkNetwork(LinksConfig.load(), seed=4)
    network.add_node("e1", "edge")
    network.add_node("f1", "fog")
    network.add_node("cloud", "cloud")
    for k in range(20_000):
        t = k * 1e-3
        network.submit(t, "e1", "f1", 500)
        network.submit(t, "f1", "cloud", 1000)
        network.submit(t, "cloud", "f1", 100)
    rec = network.records(20.0)
    ef = rec["classes"]["edge-fog"]
    assert ef["preset"] == "wifi-edge-fog"
    assert ef["datagrams_submitted"] == 20_000
    assert ef["loss_pct"] == pytest.approx(100 * (1 - ef["datagrams_delivered"] / 20_000))
    assert ef["availability_pct"] == pytest.approx(100 - ef["loss_pct"])
    assert ef["throughput_bps"] == pytest.approx(ef["bytes_delivered"] * 8 / 20.0)
    assert ef["uptime_pct"] == 100.0
    fc = rec["classes"]["fog-cloud"]
    assert fc["links"] == 2
    up, down = rec["directions"]["fog->cloud"], rec["directions"]["cloud->fog"]
    assert up["datagrams_submitted"] + down["datagrams_submitted"] == fc["datagrams_submitted"]
    # the uplink is slower and later than the downlink
    assert up["latency_ms"]["p50"] > down["latency_ms"]["p50"]
    lat = up["latency_ms"]
    assert lat["p50"] <= lat["p95"] <= lat["max"]
    airtime = network.airtime_s_by_node()
    assert airtime["e1"]["wifi"] == pytest.approx(20_000 * 528 * 8 / 520e6)
    assert airtime["f1"]["lte"] == pytest.approx(20_000 * 1028 * 8 / 50e6)
    assert airtime["cloud"]["lte"] == pytest.approx(20_000 * 128 * 8 / 150e6)


def test_same_seed_same_drops_different_seed_different():
    """Drops and arrivals repeat exactly for a seed and change with it."""

    def run(seed):
        network = _pair_network("fog-cloud", seed)
        return [network.submit(k * 1e-3, "a", "b", 300) for k in range(5000)]

    assert run(8) == run(8)
    assert run(8) != run(9)


def test_pairs_draw_independently():
    """Traffic on other pairs does not change the drops and delays on a pair."""
    config = LinksConfig.load()

    def run(other_traffic: bool):
        network = LinkNetwork(config, seed=3)
        for node, role in (("e1", "edge"), ("e2", "edge"), ("f", "fog"), ("c", "cloud")):
            network.add_node(node, role)
        out = []
        for k in range(5000):
            t = k * 1e-3
            if other_traffic:
                network.submit(t, "e2", "f", 1000)
                network.submit(t, "f", "e1", 1000)
                network.submit(t, "f", "c", 800)
            out.append(network.submit(t, "e1", "f", 300))
        return out

    assert run(False) == run(True)


def test_wifi_loss_rises_past_range():
    """Edge-edge WiFi: seed 000's loss well inside range, half beyond range_m, all far out."""
    config = LinksConfig.load()
    range_m = config.class_preset("edge-edge").up.range_m
    network = _pair_network("edge-edge", seed=5)
    network.set_position("a", (0.0, 0.0, 10.0))
    loss = {}
    for d in (0.5 * range_m, range_m, 1.3 * range_m):
        network.set_position("b", (d, 0.0, 10.0))
        results = [network.submit(k * 1e-3, "a", "b", 100) for k in range(4000)]
        loss[d / range_m] = np.mean([arrival is None for arrival, _ in results])
    assert loss[0.5] < 0.03
    assert 0.4 < loss[1.0] < 0.6
    assert loss[1.3] > 0.95
    drops = network.records(10.0)["classes"]["edge-edge"]["drops"]
    assert drops["range"] > drops["loss"]


def test_lte_coverage():
    """A fog node outside every LTE circle cannot reach the cloud; inside it can."""
    config = LinksConfig.from_dict(
        {"presets": {"lte": {"coverage": [{"centre_enu_m": [0, 0], "radius_m": 500.0}]}}}
    )
    network = LinkNetwork(config, seed=6)
    network.add_node("f", "fog")
    network.add_node("c", "cloud")  # no position: the host, always covered
    network.set_position("f", (300.0, 300.0, 20.0))
    inside = [network.submit(k * 1e-3, "f", "c", 100) for k in range(1000)]
    network.set_position("f", (400.0, 400.0, 20.0))  # 566 m from the centre
    outside = [network.submit(1.0 + k * 1e-3, "f", "c", 100) for k in range(100)]
    back = [network.submit(1.1 + k * 1e-3, "c", "f", 100) for k in range(100)]
    assert sum(a is not None for a, _ in inside) > 950
    assert all(drop is Drop.COVERAGE for _, drop in outside + back)
    assert network.records(2.0)["classes"]["fog-cloud"]["drops"]["coverage"] == 200


def test_unconfigured_class_drops_as_no_link_and_oversized_raises():
    """A class removed by the user drops as no_link; an oversized datagram raises."""
    config = LinksConfig.from_dict({"classes": {"edge-cloud": None}})
    network = LinkNetwork(config, seed=0)
    network.add_node("e", "edge")
    network.add_node("c", "cloud")
    assert network.submit(0.0, "e", "c", 10) == (None, Drop.NO_LINK)
    assert network.records(1.0)["classes"]["edge-cloud"]["drops"] == {"no_link": 1}
    network.add_node("f", "fog")
    with pytest.raises(DatagramTooLargeError):
        network.submit(0.0, "e", "f", 70_000)
    with pytest.raises(ValueError, match="unknown node 'x'"):
        network.submit(0.0, "e", "x", 10)
    with pytest.raises(ValueError, match="unknown role 'sky'"):
        network.add_node("s", "sky")


def test_mavlink_channels_are_per_vehicle_and_stable():
    """Each vehicle's link draws its own numbers; the same arguments give the same link."""
    config = LinksConfig.load()

    def run(index):
        to_v, from_v = mavlink_channels("sik", config, seed=1, vehicle_index=index)
        return [to_v.submit(k * 0.1, 100) for k in range(300)], [
            from_v.submit(k * 0.1, 100) for k in range(300)
        ]

    assert run(0) == run(0)
    assert run(0) != run(1)
    to_v, from_v = mavlink_channels("sik", config, seed=1, vehicle_index=0)
    assert to_v.params.kind == from_v.params.kind == "sik"


def test_outages_of_a_class_show_in_uptime_and_drops():
    """Random failures on the fog-cloud link: uptime_pct is the measured up share, the
    datagrams sent while down are dropped as down, and loss_pct counts them."""
    lte = {"loss": {"mean_loss": 0.0}, "outages": {"mtbf_s": 30.0, "mttr_s": 10.0}}
    config = LinksConfig.from_dict({"presets": {"lte": lte}})
    network = _pair_network("fog-cloud", seed=12, config=config)
    duration_s = 2000.0
    for k in range(int(duration_s / 0.05)):
        network.submit(k * 0.05, "a", "b", 100)
    rec = network.records(duration_s)["directions"]["fog->cloud"]
    down_share = rec["drops"]["down"] / rec["datagrams_submitted"]
    assert 100 * (1 - down_share) == pytest.approx(rec["uptime_pct"], abs=0.5)
    assert rec["uptime_pct"] == pytest.approx(75.0, abs=6.0)  # 30 / (30 + 10)
    assert rec["loss_pct"] == pytest.approx(100 * down_share)


def test_a_node_cannot_send_to_itself():
    """src == dst is a clear error, not a silent loopback."""
    network = _pair_network("edge-fog", seed=0)
    with pytest.raises(ValueError, match="sends to itself"):
        network.submit(0.0, "a", "a", 10)
