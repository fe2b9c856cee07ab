"""Network YAML: loads, names the field of every error, and names link classes by role order."""

from __future__ import annotations

import copy

import pytest

from companion.net.config import NetConfig, NetConfigError, link_class
from harness.run.ports import free_port_block

BASE = free_port_block(5)
"""Ports of the nodes below, from the suite's allocator (this xdist worker's own slice)."""

GOOD = {
    "nodes": {
        "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE}"},
        "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 1}", "groups": ["cluster1"]},
        "edge1": {"role": "edge", "address": f"localhost:{BASE + 2}", "groups": ["cluster1"]},
    },
    "routes": {"fog1": f"127.0.0.1:{BASE + 3}"},
}


def test_load_yaml_and_routes(tmp_path):
    path = tmp_path / "net.yaml"
    path.write_text(
        "nodes:\n"
        f"  cloud: {{role: cloud, address: '127.0.0.1:{BASE}'}}\n"
        f"  fog1:  {{role: fog, address: '127.0.0.1:{BASE + 1}', groups: [cluster1]}}\n"
        f"  edge1: {{role: edge, address: '127.0.0.1:{BASE + 2}', groups: [cluster1]}}\n"
        "routes:\n"
        f"  fog1: '127.0.0.1:{BASE + 3}'\n"
    )
    config = NetConfig.load(path)
    assert config.nodes["edge1"].role == "edge"
    assert config.send_address("fog1") == ("127.0.0.1", BASE + 3)
    assert config.send_address("edge1") == ("127.0.0.1", BASE + 2)
    assert config.members("cluster1") == ["fog1", "edge1"]


def test_from_env(tmp_path, monkeypatch):
    path = tmp_path / "net.yaml"
    path.write_text(f"nodes:\n  cloud: {{role: cloud, address: '127.0.0.1:{BASE}'}}\n")
    monkeypatch.setenv("SWARMSITL_NET", str(path))
    monkeypatch.setenv("SWARMSITL_NODE", "cloud")
    config, node_id = NetConfig.from_env()
    assert node_id == "cloud" and list(config.nodes) == ["cloud"]
    monkeypatch.setenv("SWARMSITL_NODE", "edge9")
    with pytest.raises(NetConfigError, match=r"SWARMSITL_NODE.*edge9"):
        NetConfig.from_env()
    monkeypatch.delenv("SWARMSITL_NET")
    with pytest.raises(NetConfigError, match="SWARMSITL_NET"):
        NetConfig.from_env()


def edit(path: str, value):
    data = copy.deepcopy(GOOD)
    *parents, last = path.split(".")
    target = data
    for key in parents:
        target = target[key]
    if value is KeyError:
        del target[last]
    else:
        target[last] = value
    return data


@pytest.mark.parametrize(
    ("path", "value", "field"),
    [
        ("nodes.edge1.role", "satellite", "nodes.edge1.role"),
        ("nodes.edge1.address", "127.0.0.1", "nodes.edge1.address"),
        ("nodes.edge1.address", "127.0.0.1:70000", "nodes.edge1.address"),
        ("nodes.edge1.address", "bad host:1", "nodes.edge1.address"),
        ("nodes.edge1.address", "999.1.1.1:5", "nodes.edge1.address"),
        pytest.param(  # the node ids must not hold the allocated port: xdist's workers differ
            "nodes.edge1.address", f"127.0.0.1:{BASE}", "nodes.edge1.address", id="duplicate"
        ),
        ("nodes.edge1.address", KeyError, "nodes.edge1.address"),
        ("nodes.edge1.role", KeyError, "nodes.edge1.role"),
        ("nodes.edge1.groups", "cluster1", "nodes.edge1.groups"),
        ("nodes.edge1.speed", 3, "nodes.edge1.speed"),
        pytest.param("routes.edge7", f"127.0.0.1:{BASE + 4}", "routes.edge7", id="unknown-route"),
        ("routes.fog1", "nowhere", "routes.fog1"),
        ("nodes", {}, "nodes"),
        ("links", {}, "links"),
    ],
)
def test_errors_name_the_field(path, value, field):
    with pytest.raises(NetConfigError, match=field.replace(".", r"\.")):
        NetConfig.from_dict(edit(path, value))


def test_unreadable_and_invalid_files(tmp_path):
    with pytest.raises(NetConfigError, match="cannot read"):
        NetConfig.load(tmp_path / "missing.yaml")
    path = tmp_path / "bad.yaml"
    path.write_text("nodes: [unclosed\n")
    with pytest.raises(NetConfigError, match="not valid YAML"):
        NetConfig.load(path)


@pytest.mark.parametrize(
    ("a", "b", "name"),
    [
        ("edge", "edge", "edge-edge"),
        ("fog", "edge", "edge-fog"),
        ("cloud", "fog", "fog-cloud"),
        ("edge", "cloud", "edge-cloud"),
        ("ground", "fog", "fog-ground"),
    ],
)
def test_link_class_orders_roles(a, b, name):
    assert link_class(a, b) == name == link_class(b, a)


def test_link_class_rejects_unknown_role():
    with pytest.raises(ValueError, match="role"):
        link_class("edge", "relay")
