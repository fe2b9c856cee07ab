"""A role program takes what peers sent while it was starting (loading its codec)."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from companion.imaging.chunks import CHUNK_TOPIC, split
from companion.imaging.jpeg_codec import jpeg_codec
from companion.net import NetConfig, Node
from companion.net.transport import UdpTransport
from companion.roles import __main__ as roles_main
from harness.run.ports import free_ports

pytestmark = pytest.mark.sockets


def test_an_image_sent_while_the_cloud_loads_its_codec_is_decoded(tmp_path, monkeypatch, capsys):
    """The node's socket is open while the codec loads (seconds, for the learned one, under
    load); a fog that started earlier already relays. The cloud's handlers must be in place
    before the node reads its first datagram, or that image is never decoded."""
    base = free_ports().net
    net = {
        "nodes": {
            "cloud": {"role": "cloud", "address": f"127.0.0.1:{base}"},
            "fog1": {"role": "fog", "address": f"127.0.0.1:{base + 1}"},
        }
    }
    path = tmp_path / "net.yaml"
    path.write_text(json.dumps(net))
    monkeypatch.setenv("SWARMSITL_NET", str(path))
    monkeypatch.setenv("SWARMSITL_NODE", "cloud")
    monkeypatch.setenv("SWARMSITL_SPEED", "50")
    monkeypatch.delenv("SWARMSITL_CLOCK_FILE", raising=False)
    monkeypatch.delenv("SWARMSITL_NET_RECORDS", raising=False)
    config = NetConfig.from_dict(net)
    fog = Node("fog1", config, UdpTransport(config, "fog1"), time.monotonic)
    codec = jpeg_codec()
    image = np.random.default_rng(0).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    meta = {"origin": "edge1", "origin_frame": 0, "level": 3, "capture_s": 0.0, "sent_s": 0.0}

    def loading_codec(name: str):
        # The cloud's socket is bound by now: the fog's image waits in it.
        for body in split(0, codec.encode(image, 3), meta, 60000):
            fog.send("cloud", CHUNK_TOPIC, body)
        time.sleep(0.05)
        return codec

    monkeypatch.setattr(roles_main, "_codec", loading_codec)
    try:
        assert roles_main.main(["--duration-s", "5", "--codec", "jpeg"]) == 0
    finally:
        fog.transport.close()
    counts = json.loads(capsys.readouterr().out.strip().splitlines()[-1])["counts"]
    assert counts["images_decoded"] == 1, counts
