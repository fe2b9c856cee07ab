"""The run's messaging network: nodes, clusters, ports, routes through the router."""

from __future__ import annotations

import pytest

from companion.net import NetConfig
from companion.roles.cluster import clusters
from harness.net.plan import NetPlan, parse_roles
from harness.run.ports import free_ports

NET = free_ports(vehicles=8)
"""Node and router port bases of the plans (from the suite's allocator, though nothing binds)."""
NODE, PROXY = NET.net, NET.net_proxy


def test_nodes_are_the_cloud_then_the_vehicles_with_fog_clusters():
    """Edges are dealt to the fogs in turn; every node gets its port and its router port."""
    plan = NetPlan(("edge", "fog", "edge", "edge", "fog"), node_base=NODE, proxy_base=PROXY)
    nodes = plan.nodes()
    assert [(n.node_id, n.role, n.vehicle) for n in nodes] == [
        ("cloud", "cloud", None),
        ("edge1", "edge", 0),
        ("fog1", "fog", 1),
        ("edge2", "edge", 2),
        ("edge3", "edge", 3),
        ("fog2", "fog", 4),
    ]
    assert [n.address[1] for n in nodes] == list(range(NODE, NODE + 6))
    assert [n.proxy_port for n in nodes] == list(range(PROXY, PROXY + 6))
    config = NetConfig.from_dict(plan.net_file())
    assert clusters(config) == {"fog1": ["edge1", "edge3"], "fog2": ["edge2"]}
    # Everyone reaches everyone through the router: the routes are the proxies.
    assert config.send_address("edge2") == ("127.0.0.1", PROXY + 3)
    assert config.nodes["edge2"].address == ("127.0.0.1", NODE + 3)


def test_without_cloud_or_fog():
    """No cloud: vehicles start at node_base; no fog: edges have no group."""
    plan = NetPlan(("edge", "edge"), cloud=False, node_base=NODE, proxy_base=PROXY)
    nodes = plan.nodes()
    assert [n.node_id for n in nodes] == ["edge1", "edge2"]
    assert nodes[0].address[1] == NODE and nodes[0].groups == ()


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"roles": ()}, "roles"),
        ({"roles": ("edge", "cloud")}, r"roles\[1\]"),
        ({"roles": ("edge",), "node_base": 80}, "node_base"),
        ({"roles": ("edge",), "proxy_base": 65535}, "proxy_base"),  # port-literal: too high
        ({"roles": ("edge", "fog"), "node_base": NODE, "proxy_base": NODE + 2}, "overlap"),
    ],
)
def test_bad_plans_name_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        NetPlan(**kwargs)


def test_parse_roles():
    """One role per vehicle, or one for all; anything else names --net."""
    assert parse_roles("edge,edge,fog", 3) == ("edge", "edge", "fog")
    assert parse_roles("edge", 2) == ("edge", "edge")
    with pytest.raises(ValueError, match="--net"):
        parse_roles("edge,fog", 3)
    with pytest.raises(ValueError, match="--net"):
        parse_roles("edge,satellite", 2)


def test_companion_and_link_models_name_the_link_classes_alike():
    """The report joins the nodes' records and the link models' by class name: the two packages
    (which may not import each other) must name every role pair the same way."""
    from itertools import product

    from companion.net import link_class
    from sitl.links.config import canonical_class

    roles = ("edge", "fog", "cloud", "ground")
    for a, b in product(roles, roles):
        assert link_class(a, b) == canonical_class(a, b)
