"""Measured packet loss of each seed-000 link class beside the paper's indoor figures.

    python -m sitl.links.report                  # 200,000 datagrams per class
    python -m sitl.links.report --datagrams 50000 --seed 3 --links my_links.yaml

Each class is measured on one pair of nodes with no positions (inside every range), datagrams of
200 B every 1 ms (no queueing): the loss is the preset's loss model alone.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from sitl.links.config import LinksConfig
from sitl.links.network import LinkNetwork

SEED_000_LOSS_PCT: dict[str, float] = {
    "edge-edge": 1.25,
    "edge-fog": 0.75,
    "fog-fog": 0.75,
    "fog-cloud": 1.99,
}
"""Seed 000 (ARCog-NET), indoor scenario, Fig. 30: packet loss per link class, %."""


def measured_loss_pct(
    config: LinksConfig, class_name: str, n_datagrams: int, seed: int
) -> tuple[float, float]:
    """Loss of a link class over ``n_datagrams`` each way, %: (lower -> higher layer, back).

    Between two nodes of one layer: (a -> b, b -> a), two independent channels.
    """
    low, high = class_name.split("-")
    network = LinkNetwork(config, seed)
    network.add_node("a", low)
    network.add_node("b", high)
    for k in range(n_datagrams):
        t = k * 1e-3
        network.submit(t, "a", "b", 200)
        network.submit(t, "b", "a", 200)
    out = []
    for src, dst in (("a", "b"), ("b", "a")):
        stats = network.channel(src, dst).stats
        out.append(100.0 * (stats.submitted - stats.delivered) / stats.submitted)
    return out[0], out[1]


def loss_table(n_datagrams: int, seed: int = 0, config: LinksConfig | None = None) -> str:
    """A Markdown table: class, preset, loss model, measured loss up/down, seed 000's figure."""
    config = LinksConfig.load() if config is None else config
    lines = [
        f"Measured loss, {n_datagrams} datagrams of 200 B each way, seed {seed}:",
        "",
        "| class | preset | model | measured a->b % | measured b->a % | seed 000 % |",
        "|---|---|---|---|---|---|",
    ]
    for class_name, paper in SEED_000_LOSS_PCT.items():
        preset = config.classes[class_name]
        model = config.presets[preset].up.loss.model.value
        up, down = measured_loss_pct(config, class_name, n_datagrams, seed)
        lines.append(f"| {class_name} | {preset} | {model} | {up:.3f} | {down:.3f} | {paper:.2f} |")
    return "\n".join(lines)


def main() -> None:
    """Print the loss table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--datagrams", type=int, default=200_000, help="per class and direction (e.g. 50000)"
    )
    parser.add_argument("--seed", type=int, default=0, help="network seed (e.g. --seed 3)")
    parser.add_argument(
        "--links", type=Path, default=None, help="a link file (e.g. --links my_links.yaml)"
    )
    args = parser.parse_args()
    print(loss_table(args.datagrams, args.seed, LinksConfig.load(args.links)))


if __name__ == "__main__":
    main()
