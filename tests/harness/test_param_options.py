"""--params: which vehicle each row loads into; client-set parameters saved on exit."""

from __future__ import annotations

from pathlib import Path

import pytest

from autopilot_emu.param_file import ParamFileError, parse_param_file
from autopilot_emu.params import ParamStore
from harness.options.params import (
    CLIENT_PARAMS_FILE,
    load_params_options,
    parse_params_option,
    save_client_params,
)

HEADER = "# Onboard parameters for Vehicle 1\n#\n# Vehicle-Id Component-Id Name Value Type\n"


def _file(tmp_path, name, rows):
    path = tmp_path / name
    path.write_text(HEADER + "".join(f"{r}\n" for r in rows))
    return path


def test_option_forms():
    assert parse_params_option("a.params") == (None, Path("a.params"))
    assert parse_params_option("2=a.params") == (2, Path("a.params"))
    assert parse_params_option("ALL=a.params") == ("all", Path("a.params"))
    target, path = parse_params_option("runs/x=1/a.params")  # '=' inside a path
    assert target is None and str(path) == "runs/x=1/a.params"


def test_a_fleet_file_loads_each_row_into_its_vehicle(tmp_path):
    path = _file(
        tmp_path,
        "fleet.params",
        ["1\t1\tMPC_XY_CRUISE\t6\t9", "3\t1\tMPC_XY_CRUISE\t8\t9", "3\t1\tBAT1_N_CELLS\t6\t6"],
    )
    load = load_params_options([str(path)], 3)
    assert load.vehicle_params == (
        {"MPC_XY_CRUISE": 6.0},
        {},
        {"MPC_XY_CRUISE": 8.0, "BAT1_N_CELLS": 6},
    )


def test_all_and_sysid_load_a_one_vehicle_file_anywhere_and_later_options_win(tmp_path):
    tuning = _file(tmp_path, "tuning.params", ["1\t1\tMPC_XY_CRUISE\t6\t9"])
    special = _file(tmp_path, "special.params", ["5\t1\tMPC_XY_CRUISE\t9\t9"])
    load = load_params_options([f"all={tuning}", f"2={special}"], 3)
    assert [p["MPC_XY_CRUISE"] for p in load.vehicle_params] == [6.0, 9.0, 6.0]


def test_a_row_of_a_vehicle_the_run_lacks_names_its_line_and_the_remedy(tmp_path):
    path = _file(tmp_path, "v3.params", ["1\t1\tMPC_XY_CRUISE\t6\t9", "3\t1\tMPC_XY_CRUISE\t6\t9"])
    with pytest.raises(ParamFileError) as info:
        load_params_options([str(path)], 2)
    assert str(info.value).startswith(f"{path}:5: vehicle id 3")
    assert "all=" in str(info.value)


def test_sysid_and_all_refuse_a_file_of_several_vehicles(tmp_path):
    path = _file(tmp_path, "two.params", ["1\t1\tMPC_XY_CRUISE\t6\t9", "2\t1\tMPC_XY_CRUISE\t6\t9"])
    for spec in (f"all={path}", f"1={path}"):
        with pytest.raises(ParamFileError) as info:
            load_params_options([spec], 2)
        assert str(info.value).startswith(f"{path}:5: vehicle id 2, but line 4 names 1")


@pytest.mark.parametrize("target", ["0", "4"])
def test_a_sysid_outside_the_run_is_refused(tmp_path, target):
    path = _file(tmp_path, "a.params", ["1\t1\tMPC_XY_CRUISE\t6\t9"])
    with pytest.raises(ValueError, match=f"no vehicle {target} in this run"):
        load_params_options([f"{target}={path}"], 3)


def test_other_components_and_mav_sys_id_are_skipped_and_said(tmp_path):
    path = _file(
        tmp_path,
        "qgc.params",
        ["1\t1\tMAV_SYS_ID\t1\t6", "1\t100\tCAM_EV_STEPS\t3\t6", "1\t1\tMPC_XY_CRUISE\t6\t9"],
    )
    load = load_params_options([f"all={path}"], 2)
    assert load.vehicle_params == ({"MPC_XY_CRUISE": 6.0}, {"MPC_XY_CRUISE": 6.0})
    (note,) = load.notes
    assert "skipped 2 row(s) (1 of MAV_SYS_ID, 1 of component 100)" in note


def test_client_set_parameters_are_saved_per_vehicle_and_load_back(tmp_path):
    stores = [ParamStore(), ParamStore()]
    stores[1].set_from_client("MPC_XY_CRUISE", 7.25)
    stores[1].set_from_client("BAT1_N_CELLS", 6)
    stores[0].set("MIS_TAKEOFF_ALT", 9.0)  # not a client's: not saved
    path = save_client_params(tmp_path, stores)
    assert path == tmp_path / CLIENT_PARAMS_FILE
    rows = parse_param_file(path.read_text())
    assert {(r.vehicle_id, r.name, r.value) for r in rows} == {
        (2, "MPC_XY_CRUISE", 7.25),
        (2, "BAT1_N_CELLS", 6),
    }
    assert load_params_options([str(path)], 2).vehicle_params == (
        {},
        {"MPC_XY_CRUISE": 7.25, "BAT1_N_CELLS": 6},
    )


def test_saving_into_a_missing_directory_logs_and_returns_none(tmp_path, caplog):
    assert save_client_params(tmp_path / "gone", [ParamStore()]) is None
    assert "could not save" in caplog.text
