"""Where a scenario's vehicles start: the same points at every fidelity.

``world_setup`` places the whole fleet in the scenario's launch area (or the world's default; one
agent start per vehicle on task maps) unless groups name their own launch area or start points;
without a world, vehicles stand ``spacing_m`` apart along east.
"""

from __future__ import annotations

import numpy as np

from harness.scenarios.spec import Scenario
from harness.sim.world_setup import WorldSetup, world_setup
from worlds.launch import default_area, spawn_points


def own_spawn_points(scenario: Scenario) -> np.ndarray | None:
    """(N, 3) start points the scenario sets itself, m; None: ``world_setup`` places the fleet."""
    spec, world = scenario.spec, scenario.world
    vehicles = scenario.vehicles
    own = any(g.start_enu_m is not None or g.launch_area is not None for g in spec.fleet)
    if world is not None and not own:
        return None
    n = spec.n_vehicles
    points = np.array([(i * spec.spacing_m, 0.0, 0.0) for i in range(n)], dtype=float)
    by_area: dict[str, list[int]] = {}
    for v in vehicles:
        g = v.group
        if g.start_enu_m is not None:
            k = sum(1 for u in vehicles[: v.index] if u.group is g)
            points[v.index] = g.start_enu_m[k]
        elif world is not None:
            area = g.launch_area or spec.launch_area or default_area(world).name
            by_area.setdefault(area, []).append(v.index)
    for area, indices in by_area.items():
        assert world is not None
        spots = spawn_points(world.launch_area(area), len(indices), spec.spacing_m)
        points[indices] = np.asarray(spots, dtype=float)
    return points


def fleet_spawn(scenario: Scenario) -> tuple[WorldSetup | None, np.ndarray]:
    """The world's setup (None without a world) and every vehicle's start point, (N, 3) m.

    Raises:
        ValueError: a launch area too small for its vehicles (naming it, its radius and n).
    """
    spec, world = scenario.spec, scenario.world
    own = own_spawn_points(scenario)
    if world is None:
        assert own is not None
        return None, own
    setup = world_setup(
        world,
        spec.n_vehicles,
        spec.launch_area,
        spec.spacing_m,
        None if own is None else tuple(tuple(p) for p in own),
    )
    return setup, np.array(setup.spawn_enu_m, dtype=float)
