"""Every CLI command documents itself with an example."""

import pytest
from typer.testing import CliRunner

from harness.cli import app


@pytest.mark.parametrize(
    "args",
    [["--help"], ["up", "--help"], ["demo", "--help"], ["cloud", "--help"], ["net-demo", "--help"]],
)
def test_help_has_example(args):
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0
    if args != ["--help"]:
        assert "Example:" in result.output


def test_up_rejects_bad_vehicle_count():
    result = CliRunner().invoke(app, ["up", "--vehicles", "0"])
    assert result.exit_code != 0


def test_ctrl_c_during_shutdown_does_not_cut_the_recordings(tmp_path, monkeypatch):
    """A second Ctrl-C that lands while ``up`` closes the simulation (tlogs, truth.csv) is only
    noted: the recordings are complete and ``up`` reports its stop normally."""
    import os
    import signal

    from harness.simulation import Simulation

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
    from harness.cli import parse_stream_rates

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
    from harness.cli import parse_gps_outages
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


@pytest.mark.parametrize("spec", ["14600", "host:", "127.0.0.1:99999", "127.0.0.1:14600+2"])
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
