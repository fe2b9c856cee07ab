"""Every CLI command documents itself with an example."""

import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from harness.cli import app

pytestmark = pytest.mark.process

REPO = Path(__file__).resolve().parents[2]
FILE_SUFFIXES = (".yaml", ".yml", ".csv", ".params", ".json", ".hex", ".tlog", ".npz", ".txt")
"""Tokens ending so name a file."""
OUTPUT_OPTIONS = ("-o", "--out", "--output", "--video")
"""Options whose value a command writes: it need not exist."""


def _commands(command=None, path=()):
    """(argv prefix, click command) of the app and of every command and sub-app below it."""
    command = typer.main.get_command(app) if command is None else command
    yield list(path), command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, (*path, name))


COMMANDS = list(_commands())
IDS = [" ".join(path) or "swarmsitl" for path, _ in COMMANDS]


def example_files(help_text):
    """File paths named as inputs in the help's ``Example:`` lines.

    Left out: an output option's value, anything under runs/ (run directories, written by an
    earlier command) and a file the example's own note writes (``> key.hex``). The note after
    `` (`` is prose; the command before it is checked.
    """
    paths = []
    for paragraph in help_text.split("\n\n"):
        paragraph = " ".join(paragraph.split())
        if not paragraph.startswith("Example:"):
            continue
        command, _, note = paragraph.removeprefix("Example:").partition(" (")
        written = {path.rstrip(").,;") for path in re.findall(r">\s*(\S+)", note)}
        tokens = command.split()
        for before, token in zip(["", *tokens], tokens, strict=False):
            name = re.split("[=,]", token)[-1].strip("'\"")
            if not name.endswith(FILE_SUFFIXES) or before in OUTPUT_OPTIONS:
                continue
            if name.startswith("runs/") or name in written:
                continue
            paths.append(name)
    return paths


@pytest.mark.parametrize(("args", "command"), COMMANDS, ids=IDS)
def test_every_command_has_an_example_naming_real_files(args, command):
    result = CliRunner().invoke(app, [*args, "--help"])
    assert result.exit_code == 0, result.output
    assert "Example:" in result.output
    missing = [p for p in example_files(command.help or "") if not (REPO / p).exists()]
    assert not missing, f"swarmsitl {' '.join(args)} --help: examples name missing {missing}"


def test_example_files_finds_inputs_and_skips_outputs():
    """The check above can fail: a made-up input is found, outputs and run files are not."""
    text = (
        "Intro.\n\nExample:  swarmsitl run my_scenario.yaml -o out.params --out runs/x\n\n"
        "Example:  swarmsitl up --params all=tuning.params --net runs/x/net.yaml   (key.hex\n"
        "from: openssl rand -hex 32 > key.hex)\n\n"
        "Example:  swarmsitl up --signing-key key.hex   (key.hex from: openssl > key.hex)"
    )
    assert example_files(text) == ["my_scenario.yaml", "tuning.params"]


def test_version_prints_the_installed_distribution_version():
    from importlib.metadata import version

    result = CliRunner().invoke(app, ["--version"])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == f"swarmsitl {version('swarmsitl')}"


def test_the_cli_prints_no_pybullet_banner():
    """PyBullet's C extension prints its build time on import; the CLI silences it."""
    result = subprocess.run(
        [sys.executable, "-c", "from harness.cli import main; main()", "--help"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert "Usage:" in result.stdout
    assert "pybullet build time" not in result.stdout + result.stderr


def test_up_rejects_bad_vehicle_count():
    result = CliRunner().invoke(app, ["up", "--vehicles", "0"])
    assert result.exit_code != 0


def test_ctrl_c_during_shutdown_does_not_cut_the_recordings(tmp_path, monkeypatch):
    """A second Ctrl-C that lands while ``up`` closes the simulation (tlogs, truth.csv) is only
    noted: the recordings are complete and ``up`` reports its stop normally."""
    import os
    import signal

    from harness.sim.simulation import Simulation

    close = Simulation.close

    def close_interrupted(self):
        os.kill(os.getpid(), signal.SIGINT)  # arrives while closing
        close(self)

    monkeypatch.setattr(Simulation, "close", close_interrupted)
    out = tmp_path / "run"
    args = ["up", "--speed", "50", "--duration", "2", "--gcs-port", "0", "--out", str(out)]
    args += ["--no-camera"]
    args += ["--sdk-port", "0", "--listen-port", "0"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "stopped at" in result.output
    assert (out / "truth.csv").stat().st_size > 0
    assert (out / "vehicle1.tlog").stat().st_size > 0


def test_stream_rate_options_parse_per_link():
    from autopilot_emu.mavlink.streams import StreamProfile
    from harness.commands.up_options import parse_stream_rates

    rates = parse_stream_rates(["ATTITUDE=20", "gcs:attitude=2", "HIGHRES_IMU=0"])
    assert rates == {
        StreamProfile.ONBOARD: {"ATTITUDE": 20.0, "HIGHRES_IMU": 0.0},
        StreamProfile.NORMAL: {"ATTITUDE": 2.0},
    }


@pytest.mark.parametrize("spec", ["ATTITUDE", "ATTITUDE=-1", "ATTITUDE=fast", "NOPE=5"])
def test_bad_stream_rate_options_are_refused_with_a_reason(spec):
    result = CliRunner().invoke(app, ["up", "--stream-rate", spec, "--duration", "1"])
    assert result.exit_code == 2  # a usage error, before anything starts
    flat = "".join(result.output.replace("│", "").split())
    assert f"'{spec}':" in flat  # the message names the bad option


@pytest.mark.parametrize("hz", ["300", "-1"])
def test_bad_mocap_rate_is_refused_with_a_reason(hz):
    """--mocap must divide the physics rate (or be 0): a usage error before anything starts."""
    result = CliRunner().invoke(app, ["up", "--mocap", hz, "--duration", "1"])
    assert result.exit_code == 2
    assert "physicsrate" in "".join(result.output.replace("│", "").split())


def test_up_with_mocap_announces_where_the_poses_go(tmp_path):
    """--mocap 50 prints the mocap target port and the bridge to run, and sends the poses."""
    import socket

    from companion import mocap_wire

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sink:
        sink.bind(("127.0.0.1", 0))
        port = sink.getsockname()[1]
        args = ["up", "--speed", "50", "--duration", "0.5", "--gcs-port", "0", "--no-camera"]
        args += ["--out", str(tmp_path), "--sdk-port", "0", "--listen-port", "0"]
        result = CliRunner().invoke(app, [*args, "--mocap", "50", "--mocap-port", str(port)])
        sink.settimeout(1.0)
        pose = mocap_wire.decode(sink.recv(128))
    assert result.exit_code == 0, result.output
    flat = "".join(result.output.split())
    assert "motioncapture:50Hz" in flat and f":{port}+i" in flat
    assert "companion.scripts.mocap_bridge" in flat
    assert pose.vehicle == 0


def test_gps_outage_options_parse_to_windows():
    """START:END for every vehicle, START:END:SYSID for one (window vehicle index = sysid - 1)."""
    from harness.commands.up_options import parse_gps_outages
    from sitl.sensors.gps import GpsOutageWindow

    assert parse_gps_outages(["30:40", "5.5:6:2"]) == (
        GpsOutageWindow(30.0, 40.0, None),
        GpsOutageWindow(5.5, 6.0, 1),
    )


@pytest.mark.parametrize("spec", ["30", "40:30", "a:b", "1:2:0"])
def test_bad_gps_outage_options_are_refused(spec):
    result = CliRunner().invoke(app, ["up", "--gps-outage", spec, "--duration", "1"])
    assert result.exit_code == 2
    assert "--gps-outage" in result.output


BAD_UDP_OUT = ["14600", "host:", "127.0.0.1:99999", "127.0.0.1:14600+2"]  # port-literal: refused
"""``--udp-out`` values refused before anything binds."""


@pytest.mark.parametrize("spec", BAD_UDP_OUT)
def test_bad_udp_out_is_refused_with_a_reason(spec):
    result = CliRunner().invoke(app, ["up", "--udp-out", spec, "--duration", "1"])
    assert result.exit_code == 2  # a usage error, before anything starts
    assert "--udp-out" in "".join(result.output.replace("│", "").split())


def test_up_with_serial_and_udp_out_prints_both(tmp_path):
    """--serial prints the serial:// URL of each vehicle's port (the symlink is removed on exit),
    --udp-out the destination of each vehicle's extra link, which writes its own tlog."""
    args = ["up", "--speed", "50", "--duration", "0.5", "--gcs-port", "0", "--no-camera", "-n", "2"]
    args += ["--out", str(tmp_path), "--sdk-port", "0", "--listen-port", "0", "--serial"]
    result = CliRunner().invoke(app, [*args, "--udp-out", "127.0.0.1:9+i"])
    assert result.exit_code == 0, result.output
    flat = "".join(result.output.split())
    for n in (1, 2):
        assert f"serial://{tmp_path}/vehicle{n}.serial:921600" in flat
        assert (tmp_path / f"vehicle{n}-serial.tlog").stat().st_size > 0
        assert (tmp_path / f"vehicle{n}-udp1.tlog").stat().st_size > 0
        assert not (tmp_path / f"vehicle{n}.serial").is_symlink()
    assert "UDPoutput1:vehiclei'sextralink(normalprofile)sendsto127.0.0.1:9+i" in flat
    assert "seriallinkofvehicle1(uart)" in flat
