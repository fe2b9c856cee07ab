"""The edge, fog and cloud role programs exchange their traffic over real UDP."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from companion.imaging.image_source import SyntheticImages
from companion.imaging.relay import project_codec
from companion.net import NetConfig, NetConfigError
from companion.roles.cluster import clusters, coordinator_of, nodes_with_role
from harness.run.ports import free_port_block, free_ports

pytestmark = pytest.mark.heavy

BASE = free_port_block(16)
"""Node ports of the configurations below (from the suite's allocator; only parsed)."""

NET = {
    "nodes": {
        "cloud": {"role": "cloud", "address": f"127.0.0.1:{BASE + 2}"},
        "fog1": {"role": "fog", "address": f"127.0.0.1:{BASE + 3}", "groups": ["c1"]},
        "edge1": {"role": "edge", "address": f"127.0.0.1:{BASE + 4}", "groups": ["c1"]},
        "edge2": {"role": "edge", "address": f"127.0.0.1:{BASE + 5}", "groups": ["c1"]},
        "edge3": {"role": "edge", "address": f"127.0.0.1:{BASE + 6}"},
    }
}


def test_clusters_follow_shared_groups():
    """An edge belongs to the fog it shares a group with; an edge without one has no fog."""
    config = NetConfig.from_dict(NET)
    assert clusters(config) == {"fog1": ["edge1", "edge2"]}
    assert coordinator_of(config, "edge2") == "fog1"
    assert coordinator_of(config, "edge3") is None
    assert nodes_with_role(config, "edge") == ["edge1", "edge2", "edge3"]


def test_a_fog_with_too_many_edges_is_refused():
    """Seed 000 caps a cluster at 9 edge agents; a tenth is a configuration error."""
    nodes = {"fog1": {"role": "fog", "address": f"127.0.0.1:{BASE}", "groups": ["c"]}}
    for k in range(10):
        nodes[f"e{k}"] = {"role": "edge", "address": f"127.0.0.1:{BASE + 6 + k}", "groups": ["c"]}
    with pytest.raises(ValueError, match=r"nodes\.fog1\.groups"):
        clusters(NetConfig.from_dict({"nodes": nodes}))
    with pytest.raises(NetConfigError):
        NetConfig.from_dict({"nodes": {"x": {"role": "satellite", "address": "1.2.3.4:5"}}})


def codec_option() -> str:
    """The roles' ``--codec``: the learned codec, installed with the package."""
    project_codec()  # raises if the shipped model cannot be loaded
    return "learned"


def test_roles_exchange_their_traffic(tmp_path):
    """Every role runs as its own process: joins, registration, images and summaries arrive.

    The images are real codec output: each edge's are decoded by the fog, which sends each on
    to the cloud re-compressed; every hop writes a row per image to ``<node>_images.csv``.
    """
    base = free_ports().net  # a block no other test or worker holds
    net = {
        "nodes": {
            k: v | {"address": f"127.0.0.1:{base + i}"}
            for i, (k, v) in enumerate(NET["nodes"].items())
            if k != "edge3"
        }
    }
    path = tmp_path / "net.yaml"
    path.write_text(json.dumps(net))  # JSON is YAML
    env = os.environ | {
        "SWARMSITL_NET": str(path),
        "SWARMSITL_SPEED": "4",
        "SWARMSITL_NET_RECORDS": str(tmp_path / "records"),
    }
    # Receivers outlive senders by several wall seconds: each process's clock starts with it,
    # and under load they start seconds apart (a cloud that started 1.5 s before the fog, with
    # 1.5 s between their planned ends, once stopped before the fog's last relay); a clean-clone
    # CI run under load still lost the last image at 4.5 s: 5 wall s fog -> edges, 7 cloud -> fog.
    duration_s = {"cloud": 60, "fog1": 32, "edge1": 12, "edge2": 12}
    pngs = tmp_path / "pngs"  # edge1 sends these; edge2 synthetic textures
    pngs.mkdir()
    for k, image in enumerate(
        SyntheticImages(np.random.default_rng(0), 64, 48)() for _ in range(2)
    ):
        cv2.imwrite(str(pngs / f"{k:05d}.png"), cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    images = {"edge1": ["--images", str(pngs)]}
    procs = {
        node: subprocess.Popen(
            [
                sys.executable,
                "-m",
                "companion.roles",
                "--duration-s",
                str(duration_s[node]),
                "--codec",
                codec_option(),
                *images.get(node, []),
            ],
            env=env | {"SWARMSITL_NODE": node},
            stdout=subprocess.PIPE,
            text=True,
        )
        for node in net["nodes"]
    }
    out = {}
    for node, proc in procs.items():
        stdout, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0, stdout
        out[node] = json.loads(stdout.strip().splitlines()[-1])["counts"]
    assert out["cloud"]["registrations"] >= 1
    assert out["cloud"]["clusters"] == {"fog1": ["edge1", "edge2"]}
    # A join or registration asked again (a peer that started later) counts again.
    assert out["fog1"]["registered"] == 1 and out["fog1"]["joins"] >= 2
    assert out["edge1"]["joined"] == out["edge2"]["joined"] == 1
    assert out["fog1"]["summaries_acked"] >= 1
    sent_images = out["edge1"]["images"] + out["edge2"]["images"]
    assert sent_images >= 2 and out["fog1"]["images"] == sent_images  # loopback loses nothing
    assert out["fog1"]["image_bytes"] == out["edge1"]["image_bytes"] + out["edge2"]["image_bytes"]
    assert out["fog1"]["images_relayed"] == sent_images
    assert out["cloud"]["images"] == out["cloud"]["images_decoded"] == sent_images
    assert out["fog1"]["frames_incomplete"] == out["cloud"]["frames_corrupt"] == 0
    rows = {}
    for node in net["nodes"]:
        with (tmp_path / "records" / f"{node}_images.csv").open() as f:
            rows[node] = list(csv.DictReader(f))
    assert len(rows["edge1"]) == out["edge1"]["images"]
    assert {(r["width_px"], r["height_px"]) for r in rows["edge1"]} == {("64", "48")}
    assert {(r["width_px"], r["height_px"]) for r in rows["edge2"]} == {("320", "240")}
    assert [r["event"] for r in rows["fog1"]].count("decoded") == sent_images
    assert all(float(r["latency_s"]) > 0 for r in rows["cloud"])
    assert out["edge1"]["images_summary"]["sent"]["bytes"] == out["edge1"]["image_bytes"]
    assert out["edge1"]["pings_answered"] >= 1
    records = json.loads((tmp_path / "records" / "fog1.json").read_text())
    assert records["peers"]["cloud"]["link_class"] == "fog-cloud"
    assert {t["name"] for t in records["tasks"]} >= {"T_conn", "T_report"}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--image-level", "9"], "--image-level 9 is not one of"),
        (["--images", "/nonexistent/dir"], "is not a directory"),
    ],
)
def test_bad_image_options_exit_2_with_a_message(tmp_path, args, message):
    path = tmp_path / "net.yaml"
    path.write_text(json.dumps({"nodes": {"edge1": NET["nodes"]["edge1"]}}))
    env = os.environ | {"SWARMSITL_NET": str(path), "SWARMSITL_NODE": "edge1"}
    proc = subprocess.run(
        [sys.executable, "-m", "companion.roles", "--codec", "jpeg", "--duration-s", "1", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2 and message in proc.stderr
    assert "Traceback" not in proc.stderr
