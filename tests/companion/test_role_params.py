"""A role's PARAMS become its dataclass; a misspelt key is an error that names it."""

from dataclasses import dataclass

import pytest

from companion.role_params import UnknownParamsError, params_from_mapping


@dataclass(frozen=True)
class _Params:
    speed_m_s: float = 5.0
    altitude_m: float = 10.0


def test_known_keys_are_taken_and_the_rest_default():
    assert params_from_mapping(_Params, {"speed_m_s": 7.0}) == _Params(7.0, 10.0)
    assert params_from_mapping(_Params, None) == _Params()


def test_an_unknown_key_names_itself_and_the_known_ones():
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['sped_m_s'\].*altitude_m"):
        params_from_mapping(_Params, {"sped_m_s": 7.0})


def test_an_unknown_key_carries_the_close_known_key_for_the_scenario_loader():
    with pytest.raises(UnknownParamsError) as info:
        params_from_mapping(_Params, {"sped_m_s": 7.0, "zzz": 1})
    assert info.value.unknown == ["sped_m_s", "zzz"]
    assert info.value.known == ["altitude_m", "speed_m_s"]
    assert "did you mean speed_m_s?" in str(info.value)
