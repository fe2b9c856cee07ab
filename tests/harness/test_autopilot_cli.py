"""`up --autopilot` and `--hil-serial` validation; `swarmsitl autopilot`'s options."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from harness.cli import app
from harness.run.ports import free_port_block
from harness.sim.external_autopilot import ExternalAutopilot, ExternalAutopilotConfig
from harness.sim.simulation import PortPlan

pytestmark = pytest.mark.sockets

UDP_CONNECT = "udp:127.0.0.1:4560"  # port-literal: PX4's simulator port, refused before binding


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["up", "--autopilot", "px5"], "expected internal or external"),
        (["up", "--hil-serial", "/dev/ttyACM0"], "needs --autopilot external"),
        (
            ["up", "-n", "2", "--autopilot", "external", "--hil-serial", "/dev/ttyACM0"],
            "one device per vehicle (2), got 1",
        ),
        (
            ["up", "--autopilot", "external", "--hil-serial", "/dev/ttyACM0:1234"],
            "baud 1234",
        ),
        (
            ["up", "--autopilot", "external", "--hil-serial", "/dev/ttyACM0", "--lockstep"],
            "--speed 1",
        ),
        (["autopilot", "--connect", UDP_CONNECT], "expected tcp:HOST:PORT"),
        (["autopilot", "--connect", "tcp:host:99999"], "expected tcp:HOST:PORT"),
    ],
)
def test_bad_options_exit_2_naming_the_problem(args, message):
    result = CliRunner().invoke(app, args, env={"COLUMNS": "200"})
    assert result.exit_code == 2
    assert message in " ".join(result.output.split()), result.output


def test_autopilot_without_a_simulator_gives_up_after_its_timeout(tmp_path):
    """Nothing listens on the port: it retries as PX4 does, then exits 1 (no hang)."""
    sdk_port = str(free_port_block())
    result = CliRunner().invoke(
        app,
        ["autopilot", "--connect", "tcp:127.0.0.1:1", "--connect-timeout", "1",
         "--listen-port", "0", "--gcs-port", "0", "--sdk-port", sdk_port],
    )  # fmt: skip
    assert result.exit_code == 1, result.output
    assert "no simulator" in result.output


def test_autopilot_with_an_unknown_airframe_exits_2():
    result = CliRunner().invoke(app, ["autopilot", "--frame", "concorde"])
    assert result.exit_code == 2
    assert "concorde" in result.output


def test_help_has_examples():
    for cmd in (["autopilot", "--help"], ["up", "--help"]):
        out = CliRunner().invoke(app, cmd, env={"COLUMNS": "200"}).output
        assert "Example:" in out and "autopilot" in out


def test_the_autopilot_loads_its_own_rows_of_a_parameter_file(tmp_path):
    """A fleet file: instance 1 (system id 2) takes the rows of vehicle 2 only."""
    path = tmp_path / "fleet.params"
    path.write_text("# fleet\n1\t1\tMPC_XY_CRUISE\t7.5\t9\n2\t1\tMPC_XY_CRUISE\t3.5\t9\n")
    sdk_port = free_port_block()
    result = CliRunner().invoke(
        app,
        ["autopilot", "--instance", "1", "--params", str(path), "--connect", "tcp:127.0.0.1:1",
         "--connect-timeout", "0.5", "--listen-port", "0", "--gcs-port", "0",
         "--sdk-port", str(sdk_port)],
    )  # fmt: skip
    assert result.exit_code == 1, result.output  # no simulator, after loading
    assert "1 parameter(s) from" in result.output
    ap = ExternalAutopilot(
        ExternalAutopilotConfig(
            instance=1,
            params=(("MPC_XY_CRUISE", 3.5),),
            ports=PortPlan(listen_base=0, gcs_port=0, sdk_base=sdk_port),
        )
    )
    try:
        store = ap.fleet.params[0]
        assert store.get("MPC_XY_CRUISE") == pytest.approx(3.5)
        assert store.get("MAV_SYS_ID") == 2
    finally:
        ap.close()
