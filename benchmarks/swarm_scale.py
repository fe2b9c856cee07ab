"""Swarm scale: wall time per simulated second from 1 to 1000 nodes, and sweep throughput on Dask.

Two measurements, one run:

1. For N = 1, 10, 100, 1000 (``--sizes``): the shipped ``swarm_coverage`` scenario at
   ``fidelity: swarm`` with N vehicles (kinematic, 10 Hz), every node deciding every simulated
   second (its coverage program) and telling its radio neighbours (6 nearest within WiFi range)
   where it is and what it saw, through the link model; wall seconds per simulated second of
   ``run_swarm`` (planning, decisions, messages, report) and the real-time factor. The plot of
   wall time per simulated second against N goes to ``--plot``.
2. Sweep throughput: the same ``--trials`` trials (``--trial-size`` vehicles, seeds 0..T-1) run
   one after the other in this process, then on the LocalCluster of ``swarmsitl sweep --workers
   2`` (2 worker processes, one thread each); trials per minute of each and their ratio. The
   cluster's start-up is not counted, and each process (this one and each worker) first runs one
   untimed trial of the same size, as a long sweep amortises both.

    python benchmarks/swarm_scale.py
    python benchmarks/swarm_scale.py --sizes 1,10,100 --trials 4     # quicker
    python benchmarks/swarm_scale.py --sizes "" --trials 8           # the sweep throughput only
    python benchmarks/swarm_scale.py --sizes 1000 --trials 0         # the 1000 nodes only

The last line is ``RESULT rtf_1000=... trials_per_min_2w=... speedup_2w=...`` (plus the other
sizes' real-time factors).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness.scenarios import scenario_path
from harness.scenarios.spec import Scenario, parse_scenario
from harness.swarm.run import run_swarm
from harness.sweep.runner import open_client
from realtime_factor import machine


def swarm_scenario(n: int) -> Scenario:
    """The shipped swarm_coverage scenario with ``n`` vehicles."""
    path = scenario_path("swarm_coverage")
    spec = yaml.safe_load(path.read_text())
    spec["fleet"][0]["count"] = n
    return parse_scenario(yaml.safe_dump(spec), str(path), path.parent)


def trial(n: int, seed: int) -> dict[str, float]:
    """One sweep trial: the scenario with ``n`` vehicles and ``seed``; its headline metrics."""
    report = run_swarm(swarm_scenario(n), seed)
    return {
        "coverage_fraction": report["fleet"]["companions"]["coverage_fraction"]["value"],
        "sim_time_s": report["sim_time_s"],
    }


def scale(sizes: list[int]) -> dict[int, tuple[float, float, float]]:
    """N -> (simulated s, wall s, decisions) of one run each (after a warm-up run, not timed)."""
    run_swarm(swarm_scenario(1), 0)  # lazy imports and first-call costs out of the timings
    out = {}
    for n in sizes:
        scenario = swarm_scenario(n)
        t0 = time.perf_counter()
        report = run_swarm(scenario, 0)
        wall = time.perf_counter() - t0
        sim = report["sim_time_s"]
        decisions = report["fleet"]["decisions"]["value"]
        out[n] = (sim, wall, decisions)
        print(
            f"N = {n:5d}: {sim:6.1f} s simulated in {wall:7.2f} s wall: "
            f"{wall / sim * 1e3:8.2f} ms per simulated s, {sim / wall:7.2f}x real time, "
            f"{1e3 * report['wall']['decision_ms'] / 1e3:.3f} ms per decision, "
            f"{report['fleet']['datagrams_submitted']['value']} datagrams, "
            f"coverage {report['fleet']['companions']['coverage_fraction']['value']:.3f}",
            flush=True,
        )
    return out


def plot(results: dict[int, tuple[float, float, float]], path: Path) -> None:
    """Wall seconds per simulated second against N, log-log."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = sorted(results)
    per_s = [results[n][1] / results[n][0] for n in sizes]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.loglog(sizes, per_s, "o-", label="swarm_coverage, fidelity swarm")
    ax.axhline(1.0, color="grey", linestyle="--", label="real time")
    ax.set_xlabel("nodes N")
    ax.set_ylabel("wall s per simulated s")
    ax.set_title("Swarm-scale engine: cost of one simulated second")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def throughput(trials: int, size: int) -> tuple[float, float, float]:
    """(serial trials/min, 2-worker trials/min, cluster start-up s).

    Each process first runs one untimed trial of the same size (seed ``trials``): what every
    process of a long sweep pays once (lazy imports, the shared split of the area).
    """
    trial(size, trials)
    t0 = time.perf_counter()
    serial = [trial(size, seed) for seed in range(trials)]
    serial_min = (time.perf_counter() - t0) / 60.0
    t0 = time.perf_counter()
    with open_client(None, 2) as client:  # the sweep's LocalCluster, as `swarmsitl sweep` has it
        workers = list(client.scheduler_info()["workers"])
        warm = [client.submit(trial, size, trials, workers=[w], pure=False) for w in workers]
        client.gather(warm)
        startup = time.perf_counter() - t0
        t0 = time.perf_counter()
        futures = [client.submit(trial, size, seed, pure=False) for seed in range(trials)]
        parallel = client.gather(futures)
        parallel_min = (time.perf_counter() - t0) / 60.0
    if parallel != serial:
        raise SystemExit("the 2-worker results differ from the serial ones: not deterministic")
    return trials / serial_min, trials / parallel_min, startup


def main() -> None:
    """Measure, print, plot; last line RESULT."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default="1,10,100,1000", help="fleet sizes, comma-separated")
    parser.add_argument("--trials", type=int, default=8, help="trials of the throughput test")
    parser.add_argument("--trial-size", type=int, default=50, help="vehicles per trial")
    parser.add_argument("--plot", type=Path, default=Path("runs/benchmarks/swarm_scale.png"))
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",") if s]
    print(f"machine: {machine()}")
    results = scale(sizes)
    if results:
        plot(results, args.plot)
        print(f"plot: {args.plot}")
    figures = [f"rtf_{n}={results[n][0] / results[n][1]:.2f}" for n in sizes]
    if args.trials > 0:  # --trials 0: the scale measurement alone (e.g. under a profiler)
        serial, parallel, startup = throughput(args.trials, args.trial_size)
        print(
            f"sweep of {args.trials} trials x {args.trial_size} vehicles: serial {serial:.1f} "
            f"trials/min, 2 Dask workers {parallel:.1f} trials/min ({parallel / serial:.2f}x; "
            f"cluster start-up and warm-up {startup:.1f} s, not counted)"
        )
        figures += [
            f"trials_per_min_2w={parallel:.1f}",
            f"trials_per_min_serial={serial:.1f}",
            f"speedup_2w={parallel / serial:.2f}",
        ]
    print("RESULT " + " ".join(figures))


if __name__ == "__main__":
    main()
