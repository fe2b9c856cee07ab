"""Dotted scenario parameters resolve against the scenario file and its schema."""

from pathlib import Path

import pytest
import yaml

from harness.sweep.params import ParameterError, apply_parameters, set_parameter

DATA = Path(__file__).with_name("data")


def tiny():
    return yaml.safe_load((DATA / "tiny.yaml").read_text())


def test_a_value_of_the_file_a_list_index_and_a_role_argument_are_set():
    data = apply_parameters(
        tiny(), {"fleet.0.count": 7, "roles.survey.args.speed_m_s": 12, "duration_s": 5}
    )
    assert data["fleet"][0]["count"] == 7
    assert data["roles"]["survey"]["args"]["speed_m_s"] == 12
    assert data["duration_s"] == 5
    assert tiny()["fleet"][0]["count"] == 2  # the original is untouched


def test_a_schema_field_the_file_leaves_at_its_default_is_created():
    data = apply_parameters(tiny(), {"swarm.step_hz": 20.0, "fleet.0.airframe": "x500"})
    assert data["swarm"] == {"step_hz": 20.0}
    assert data["fleet"][0]["airframe"] == "x500"


@pytest.mark.parametrize(
    ("dotted", "message"),
    [
        ("fleet.0.cout", "fleet.0 has no 'cout'; did you mean count?"),
        ("duraton_s", "the scenario has no 'duraton_s'; did you mean duration_s"),
        ("roles.survey.args.sped_m_s", "did you mean speed_m_s?"),
        ("fleet.1.count", "fleet has 1 entries; no index 1"),
        ("fleet.first.count", "'first' is not an index"),
        ("duration_s.value", "duration_s is a value (30), not a section"),
        ("fleet..count", "not a dotted parameter name"),
    ],
)
def test_a_path_that_leads_nowhere_is_an_error_naming_the_part_and_the_close_matches(
    dotted, message
):
    with pytest.raises(ParameterError) as err:
        set_parameter(tiny(), dotted, 1)
    assert message in str(err.value)
