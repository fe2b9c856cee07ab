"""World YAML schema: shipped examples load; bad files fail naming file, line and field."""

import re

import pytest

from worlds import WorldSpecError, build, load_world, parse_world
from worlds.examples import KINDS, example_path


@pytest.mark.parametrize("kind", KINDS)
def test_shipped_example_loads_and_builds(kind):
    spec = load_world(example_path(kind))
    assert spec.kind == kind
    world = build(spec)
    assert world.kind == kind and world.seed == spec.seed
    assert world.boundary.area > 0


def _error(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(WorldSpecError) as info:
        load_world(path)
    return str(path), str(info.value)


def test_unknown_key_names_file_line_and_key(tmp_path):
    path, msg = _error(tmp_path, "kind: city\nseed: 3\nblocks: [2, 2]\nbuildng_height_m: [5, 9]\n")
    assert msg == f"{path}:4: buildng_height_m: unknown key"


def test_wrong_type_names_the_line_of_the_value_and_the_field_path(tmp_path):
    text = "kind: offshore\nseed: 1\nspill_radius_m:\n  - 5.0\n  - lots\n"
    path, msg = _error(tmp_path, text)
    assert msg.startswith(f"{path}:5: spill_radius_m.1: ")
    assert "number" in msg


def test_missing_field_names_the_mapping_and_field(tmp_path):
    path, msg = _error(tmp_path, "# a comment\nkind: indoor\nrooms: [2, 2]\n")
    assert re.match(rf"{re.escape(path)}:2: seed: missing field", msg)


def test_missing_or_unknown_kind(tmp_path):
    path, msg = _error(tmp_path, "seed: 1\n")
    assert msg.startswith(f"{path}:1: kind: missing field")
    path, msg = _error(tmp_path, "seed: 1\nkind: moon\n")
    assert msg.startswith(f"{path}:2: kind: unknown kind 'moon'")


def test_duplicate_key_is_an_error_not_silently_the_last(tmp_path):
    path, msg = _error(tmp_path, "kind: city\nseed: 1\nblocks: [2, 2]\nseed: 2\n")
    assert msg == f"{path}:4: seed: duplicate key"


def test_several_errors_are_all_reported(tmp_path):
    path, msg = _error(tmp_path, "kind: taskmap\nseed: -1\ntask_count: 3.5\nfoo: 1\n")
    lines = msg.splitlines()
    assert any(line.startswith(f"{path}:2: seed:") for line in lines)
    assert any(line.startswith(f"{path}:3: task_count:") for line in lines)
    assert f"{path}:4: foo: unknown key" in lines


def test_reversed_range_and_bad_colour_are_rejected():
    with pytest.raises(WorldSpecError, match=r"<string>:3: building_height_m: .*min <= max"):
        parse_world("kind: city\nseed: 0\nbuilding_height_m: [50, 10]\n")
    with pytest.raises(WorldSpecError, match=r"<string>:3: sea_rgba.2: "):
        parse_world("kind: offshore\nseed: 0\nsea_rgba: [0, 0, 2, 1]\n")


def test_invalid_yaml_and_non_mapping_and_missing_file(tmp_path):
    with pytest.raises(WorldSpecError, match=r"<string>:2: not valid YAML"):
        parse_world("kind: city\nseed: 1: 2\n")
    with pytest.raises(WorldSpecError, match="a mapping"):
        parse_world("- 1\n- 2\n")
    with pytest.raises(WorldSpecError, match="cannot read"):
        load_world(tmp_path / "nope.yaml")


def test_a_spec_that_cannot_fit_fails_naming_the_field():
    spec = parse_world(
        "kind: offshore\nseed: 0\nsize_m: [300, 300]\nspill_count: 60\nspill_radius_m: [20, 30]\n"
    )
    with pytest.raises(ValueError, match="spill_count"):
        build(spec)
    spec = parse_world("kind: city\nseed: 0\nsize_m: [100, 100]\nblocks: [8, 8]\n")
    with pytest.raises(ValueError, match="blocks"):
        build(spec)
