"""--params and the client-set parameters file in real runs: over MAVLink, through the CLI."""

from __future__ import annotations

import dataclasses
import os
import signal
import socket
import threading
import time

import pytest
from mission_link import SimLink
from pymavlink.dialects.v20 import common as mavlink2
from typer.testing import CliRunner

from autopilot_emu.param_file import parse_param_file, read_param_file
from autopilot_emu.params import MAV_PARAM_TYPE_REAL32, decode_param_value, encode_param_value
from harness.cli import app
from harness.options.params import CLIENT_PARAMS_FILE, load_params_options
from harness.run.ports import free_port_block
from harness.sim.simulation import Simulation, SimulationConfig
from sitl.world import WorldConfig

pytestmark = pytest.mark.sockets


def _read(link: SimLink, name: str) -> float:
    link.send(mavlink2.MAVLink_param_request_read_message(1, 1, name.encode(), -1))
    reply = link.wait_type("PARAM_VALUE", param_id=name)
    return decode_param_value(reply.param_value, reply.param_type)


def _flat(text: str) -> str:
    return "".join(text.replace("│", "").split())


def test_params_file_values_are_what_a_client_reads_and_its_sets_come_back_next_run(tmp_path):
    """A file's value is what PARAM_REQUEST_READ returns; a PARAM_SET of the run is saved in
    client_params.params on close, and a run started from that file reads it back."""
    tuning = tmp_path / "tuning.params"
    tuning.write_text("# Vehicle-Id Component-Id Name Value Type\n1\t1\tMPC_XY_CRUISE\t7.5\t9\n")
    load = load_params_options([f"all={tuning}"], 1)
    link = SimLink.open(vehicle_params=load.vehicle_params, out_dir=tmp_path / "run1")
    try:
        assert _read(link, "MPC_XY_CRUISE") == 7.5
        value = encode_param_value(42.5, MAV_PARAM_TYPE_REAL32)
        link.send(
            mavlink2.MAVLink_param_set_message(
                1, 1, b"RTL_RETURN_ALT", value, MAV_PARAM_TYPE_REAL32
            )
        )
        link.wait_type("PARAM_VALUE", param_id="RTL_RETURN_ALT")
    finally:
        link.close()
    saved = tmp_path / "run1" / CLIENT_PARAMS_FILE
    assert [(r.vehicle_id, r.name, r.value) for r in read_param_file(saved)] == [
        (1, "RTL_RETURN_ALT", 42.5)
    ]
    load = load_params_options([str(saved)], 1)
    link = SimLink.open(vehicle_params=load.vehicle_params, out_dir=tmp_path / "run2")
    try:
        assert _read(link, "RTL_RETURN_ALT") == 42.5
        assert _read(link, "MPC_XY_CRUISE") == 5.0  # the default again: not a client's set
    finally:
        link.close()


def test_up_loads_the_file_and_leaves_the_client_params_file_at_duration_end(tmp_path):
    tuning = tmp_path / "tuning.params"
    tuning.write_text("1\t1\tMPC_XY_CRUISE\t7.5\t9\n1\t100\tCAM_EV_STEPS\t3\t6\n")
    out = tmp_path / "run"
    args = ["up", "--lockstep", "--duration", "0.5", "--gcs-port", "0", "--no-camera"]
    args += ["--out", str(out), "--sdk-port", "0", "--listen-port", "0"]
    result = CliRunner().invoke(app, [*args, "--params", f"all={tuning}"])
    assert result.exit_code == 0, result.output
    flat = _flat(result.output)
    assert f"parametersfrom{tuning}:1pervehicle" in flat
    assert "skipped1row(s)(1ofcomponent100)" in flat
    assert parse_param_file((out / CLIENT_PARAMS_FILE).read_text()) == ()


def test_up_refuses_a_bad_file_with_one_line_naming_file_and_line(tmp_path):
    bad = tmp_path / "bad.params"
    bad.write_text("# saved\n1\t1\tMPC_XY_CRUISE\t7.5\t9\n1\t1\tNO_SUCH\t1\t9\n")
    for spec, says in ((str(bad), f"{bad}:3: unknown parameter 'NO_SUCH'"), ("nope.params", "")):
        result = CliRunner().invoke(app, ["up", "--params", spec, "--duration", "1"])
        assert result.exit_code == 2
        (line,) = result.output.strip().splitlines()
        assert line.startswith(f"error: {says or 'nope.params: '}"), line


def test_up_suggests_the_parameter_a_misspelt_row_meant(tmp_path):
    bad = tmp_path / "typo.params"
    bad.write_text("1\t1\tMPC_XY_CRUSE\t7.5\t9\n")
    result = CliRunner().invoke(app, ["up", "--params", f"all={bad}", "--duration", "1"])
    assert result.exit_code == 2
    (line,) = result.output.strip().splitlines()
    assert line.startswith(f"error: {bad}:1: unknown parameter 'MPC_XY_CRUSE'; did you mean "), line
    assert "MPC_XY_CRUISE" in line


def test_ctrl_c_saves_what_a_client_set_over_mavlink(tmp_path):
    """A pymavlink client sets a parameter during `swarmsitl up`, then Ctrl-C: the run's
    client_params.params holds it (and the tlog and truth.csv are written as always)."""
    out = tmp_path / "run"
    errors: list[BaseException] = []
    up_returned = threading.Event()
    up_port = free_port_block(2)  # the vehicle listens here, the client at up_port + 1
    up_sdk_port = up_port + 1

    def client() -> None:
        try:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
                sock.bind(("127.0.0.1", up_sdk_port))
                sock.settimeout(0.2)
                mav = mavlink2.MAVLink(None, srcSystem=245, srcComponent=190)
                value = encode_param_value(33.0, MAV_PARAM_TYPE_REAL32)
                msg = mavlink2.MAVLink_param_set_message(
                    1, 1, b"RTL_RETURN_ALT", value, MAV_PARAM_TYPE_REAL32
                )
                deadline = time.monotonic() + 60.0
                while time.monotonic() < deadline and not up_returned.is_set():
                    sock.sendto(msg.pack(mav), ("127.0.0.1", up_port))
                    try:
                        data = sock.recv(65535)
                    except (TimeoutError, ConnectionRefusedError):
                        continue
                    for m in mav.parse_buffer(data) or []:
                        if m.get_type() == "PARAM_VALUE" and m.param_id == "RTL_RETURN_ALT":
                            return
                raise AssertionError("no PARAM_VALUE echo within 60 s")
        except BaseException as exc:
            errors.append(exc)
        finally:
            if not up_returned.is_set():  # up still runs (its handler notes the signal)
                os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C

    args = ["up", "--duration", "600", "--gcs-port", "0", "--no-camera", "--out", str(out)]
    args += ["--listen-port", str(up_port), "--sdk-port", str(up_sdk_port)]
    thread = threading.Thread(target=client)
    thread.start()
    try:
        result = CliRunner().invoke(app, args)
    finally:
        up_returned.set()
        thread.join()
    assert not errors, errors
    assert result.exit_code == 0, result.output
    rows = read_param_file(out / CLIENT_PARAMS_FILE)
    assert [(r.vehicle_id, r.name, r.value) for r in rows] == [(1, "RTL_RETURN_ALT", 33.0)]
    assert "1parameter(s)setbyclientssaved" in _flat(result.output)
    assert (out / "vehicle1.tlog").stat().st_size > 0 and (out / "truth.csv").exists()


def test_dump_writes_the_start_values_and_up_takes_them_back_unchanged(tmp_path):
    """`params dump` of a mixed fleet holds each vehicle's start values (the x500's own
    SYS_AUTOSTART); loading it back with --params leaves every store as it was."""
    path = tmp_path / "fleet.params"
    args = ["params", "dump", "-n", "2", "--frame", "typhoon_h480,x500", "-o", str(path)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    rows = read_param_file(path)
    config = SimulationConfig(
        n_vehicles=2,
        frames=("typhoon_h480", "x500"),
        mavlink=False,
        record_hz=0,
        world=WorldConfig(rangefinders=True),
    )
    with Simulation(config) as sim:
        expected = {
            (i + 1, name): store.get(name)
            for i, store in enumerate(sim.fleet.params)
            for name in store.names
        }
    assert {(r.vehicle_id, r.name): r.value for r in rows} == expected
    assert expected[(1, "SYS_AUTOSTART")] != expected[(2, "SYS_AUTOSTART")]
    load = load_params_options([str(path)], 2)
    with Simulation(dataclasses.replace(config, vehicle_params=load.vehicle_params)) as sim:
        again = {
            (i + 1, name): store.get(name)
            for i, store in enumerate(sim.fleet.params)
            for name in store.names
        }
    assert again == expected


def test_dump_of_one_vehicle_is_a_qgroundcontrol_file_for_it():
    result = CliRunner().invoke(app, ["params", "dump", "-n", "3", "--sysid", "2"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0] == "# Onboard parameters for Vehicle 2"
    body = [line for line in lines if line and not line.startswith("#")]
    assert all(line.split("\t")[:2] == ["2", "1"] for line in body)
    assert {line.split("\t")[4] for line in body} == {"6", "9"}


def test_params_dump_help_has_an_example():
    result = CliRunner().invoke(app, ["params", "dump", "--help"])
    assert result.exit_code == 0 and "Example:" in result.output
