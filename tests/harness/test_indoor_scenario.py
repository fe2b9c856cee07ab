"""The shipped indoor scenario file: valid, and its companions split the plant's rooms."""

from __future__ import annotations

import numpy as np

from companion.scripts.indoor_search import SearchParams, launch_reference


def test_the_shipped_scenario_splits_the_plant_among_its_vehicles() -> None:
    """The indoor scenario's companions, planning as they would: all rooms, no room twice."""
    from companion.planning.indoor_route import IndoorPlanner, RouteSpec
    from companion.scripts.indoor_search import plan_route, room_arcs
    from harness.scenarios import scenario_path
    from harness.scenarios.spec import load_scenario
    from harness.sim.world_setup import world_setup

    scenario = load_scenario(scenario_path("indoor"))
    spec, world = scenario.spec, scenario.world
    assert world is not None and world.gps_denied
    setup = world_setup(world, spec.n_vehicles, spec.launch_area, spec.spacing_m)
    params = SearchParams.from_mapping(spec.roles["search"].args)
    seen: list[int] = []
    for k, spawn in enumerate(setup.spawn_enu_m):
        planner = IndoorPlanner(
            world, RouteSpec(params.height_m(k), params.margin_m, params.resolution_m)
        )
        reference, off = launch_reference(world, np.array(spawn[:2]))
        assert off <= 2.0
        route, mine = plan_route(planner, tuple(reference), spawn[:2], k, spec.n_vehicles, 1e9)
        assert route.rooms == mine and len(mine) >= 1
        arcs = room_arcs(route)
        assert list(arcs) == list(mine)
        assert all(0.0 < a < route.length_m for a in arcs.values())
        seen += mine
    assert sorted(seen) == list(range(6))
