"""The link file: user files merge over the presets; bad files fail naming the field."""

from __future__ import annotations

import re
import shutil

import pytest

from sitl.links.config import PRESETS_PATH, LinksConfig
from sitl.links.params import LinkConfigError


def test_shipped_presets_load_with_sources_for_every_preset():
    """The shipped file loads; seed 000's classes map to presets; LTE is asymmetric."""
    config = LinksConfig.load()
    assert set(config.classes) >= {"edge-edge", "edge-fog", "fog-fog", "fog-cloud"}
    up, down = config.link("fog-cloud")
    assert (up.rate_bps, down.rate_bps) == (50e6, 150e6)
    assert config.link("cloud-fog") == (up, down)  # either role order
    assert config.link("uart")[0].bits_per_byte == 10


def test_a_copied_preset_file_loads_the_same(tmp_path):
    """A user's copy of presets.yaml loads to the same configuration."""
    copy = tmp_path / "links.yaml"
    shutil.copy(PRESETS_PATH, copy)
    assert LinksConfig.load(copy).presets == LinksConfig.load().presets


def test_user_file_overrides_one_field_and_adds_a_preset(tmp_path):
    """A user file changes one number of a preset and adds a preset and a class mapping."""
    path = tmp_path / "links.yaml"
    path.write_text(
        "presets:\n"
        "  lte:\n"
        "    up: {rate_bps: 20000000}\n"
        "  wifi-long:\n"
        "    base: wifi\n"
        "    range_m: 300.0\n"
        "classes:\n"
        "  fog-edge: wifi-long\n"
    )
    config = LinksConfig.load(path)
    up, down = config.link("lte")
    assert up.rate_bps == 20e6 and down.rate_bps == 150e6
    assert up.loss.mean_loss == 0.0199  # untouched fields keep the shipped values
    assert config.classes["edge-fog"] == "wifi-long"
    assert config.link("edge-fog")[0].range_m == 300.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("classes:\n  edge-fog: wifii\n", "classes.edge-fog: unknown preset 'wifii'"),
        ("classes:\n  edge-sky: wifi\n", "classes.edge-sky: unknown class 'edge-sky'"),
        (
            "presets:\n  lte:\n    up: {latency: {base_s: -0.01}}\n",
            "presets.lte.up.latency.base_s: must be >= 0 s",
        ),
        (
            "presets:\n  lte:\n    loss: {mean_loss: 1.5}\n",
            "presets.lte.up.loss.mean_loss: must be within 0..1",
        ),
        ("presets:\n  wifi:\n    rang_m: 80\n", "presets.wifi.rang_m: unknown field"),
        ("presets:\n  wifi:\n    rate_bps: 5.2e8\n", "presets.wifi.rate_bps: must be a number"),
        ("presets:\n  mine: {base: wify}\n", "presets.mine.base: unknown preset 'wify'"),
        ("presets:\n  lte:\n    coverage: [{radius_m: 5}]\n", "presets.lte.coverage[0]"),
        ("links:\n  a: 1\n", "links: unknown section"),
        ("presets: [1, 2]\n", "presets: must be a mapping"),
    ],
)
def test_bad_link_files_fail_at_load_naming_the_field(tmp_path, text, message):
    """Unknown class or preset, negative latency, loss above 1, unknown field: a clear error."""
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(LinkConfigError, match=re.escape(message)) as info:
        LinksConfig.load(path)
    assert str(path) in str(info.value)


def test_missing_file_is_a_clear_error(tmp_path):
    """A path that does not exist names itself."""
    with pytest.raises(LinkConfigError, match="cannot read the link file"):
        LinksConfig.load(tmp_path / "nope.yaml")


def test_an_inline_mapping_merges_over_the_file_as_the_file_over_the_shipped(tmp_path):
    """Layers: a class either layer names in either role order; an error names its layer."""
    path = tmp_path / "links.yaml"
    path.write_text("presets:\n  mesh: {base: wifi, range_m: 50.0}\nclasses:\n  fog-edge: mesh\n")
    inline = {"presets": {"mesh": {"range_m": 5.0}}, "classes": {"edge-fog": "lte"}}
    config = LinksConfig.load(path, inline)
    assert config.presets["mesh"].up.range_m == 5.0
    assert config.presets["mesh"].up.rate_bps == config.presets["wifi"].up.rate_bps
    assert config.classes["edge-fog"] == "lte"
    assert LinksConfig.load(path).classes["edge-fog"] == "mesh"
    assert (
        LinksConfig.load(None, inline={"classes": {"edge-edge": None}}).classes.get("edge-edge")
        is None
    )
    with pytest.raises(LinkConfigError, match=r"^presets\.mesh\.range_m: must be"):
        LinksConfig.load(path, {"presets": {"mesh": {"range_m": -1.0}}})
    path.write_text("presets:\n  mesh: {base: wiffi}\n")
    with pytest.raises(LinkConfigError, match=re.escape(f"{path}: presets.mesh.base: unknown")):
        LinksConfig.load(path, inline)
