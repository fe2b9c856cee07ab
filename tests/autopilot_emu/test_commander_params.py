"""CommanderParams: every field follows the PX4 parameter it names; the commander rebuilds it."""

import ast
import dataclasses
import inspect

import numpy as np
import pytest

from autopilot_emu import commander_params
from autopilot_emu.commander import Commander, NavInput
from autopilot_emu.commander_params import CommanderParams
from autopilot_emu.params import MAV_PARAM_TYPE_INT32, ParamStore


def _px4_name_of_each_field() -> dict[str, str]:
    """Field -> the PX4 name its docstring starts with ("NAV_ACC_RAD: ...")."""
    body = ast.parse(inspect.getsource(commander_params)).body
    cls = next(n for n in body if isinstance(n, ast.ClassDef) and n.name == "CommanderParams")
    names = {}
    for field, doc in zip(cls.body, cls.body[1:], strict=False):
        if isinstance(field, ast.AnnAssign) and isinstance(doc, ast.Expr):
            names[field.target.id] = doc.value.value.split(":")[0]
    return names


NAMES = _px4_name_of_each_field()


def test_every_field_names_a_px4_parameter_of_the_store():
    assert set(NAMES) == {f.name for f in dataclasses.fields(CommanderParams)}
    store = ParamStore()
    for name in NAMES.values():
        store.spec(name)  # raises for an unknown name


@pytest.mark.parametrize("field", sorted(NAMES))
def test_each_field_follows_its_parameter_and_only_it(field):
    """A value other than the default, set on the named parameter, shows in that field alone;
    INT32 enums give int fields, the others (COM_DL_LOSS_T, an INT32 duration, too) the float
    the store holds."""
    store = ParamStore()
    before = CommanderParams.from_params(store)
    name = NAMES[field]
    spec = store.spec(name)
    value = spec.max_value if spec.default != spec.max_value else spec.min_value
    store.set(name, value)
    after = CommanderParams.from_params(store)
    changed = {
        f.name
        for f in dataclasses.fields(after)
        if getattr(after, f.name) != getattr(before, f.name)
    }
    assert changed == {field}
    got = getattr(after, field)
    if spec.mav_type == MAV_PARAM_TYPE_INT32 and name != "COM_DL_LOSS_T":
        assert type(got) is int and got == value
    else:
        assert type(got) is float and got == float(store.get(name))


def _nav(t):
    return NavInput(t, np.zeros(3), np.zeros(3), 0.0, True, 0.0, 488.0)


def test_a_param_set_takes_effect_at_the_next_tick_and_reaches_the_failsafes():
    c = Commander(ParamStore())
    first = c._settings()
    c.update(_nav(0.0))
    assert c._settings() is first  # unchanged store: nothing rebuilt
    c.params.set_from_client("MPC_XY_CRUISE", 3.0)
    c.params.set_from_client("NAV_DLL_ACT", 3)
    out = c.update(_nav(0.02))
    assert out.max_speed_xy_m_s == pytest.approx(3.0)
    assert c.failsafe.params.datalink_loss_action == 3
    assert c.failsafe.params is c._settings()
