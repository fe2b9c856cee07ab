"""The pytest plugin's parts that need no flight: ports, the report's verdict, the entry point."""

import itertools
import json
import random
import socket
from importlib import metadata

import pytest

from harness.pytest_plugin import RunResult, free_ports
from harness.run import ports as run_ports
from harness.run.ports import PORTS_HIGH, PORTS_LOW, free_port_block, worker_slice

pytestmark = pytest.mark.sockets


def test_the_plugin_is_registered_for_every_pytest_session():
    entry = [e for e in metadata.entry_points(group="pytest11") if e.name == "swarmsitl"]
    assert [e.value for e in entry] == ["harness.pytest_plugin"]


def test_free_ports_skips_a_block_someone_holds(monkeypatch):
    monkeypatch.setattr(run_ports, "_HANDED_OUT", [])  # the free check alone must skip it
    rng = random.Random(3)
    first = free_ports(vehicles=4, rng=random.Random(3))
    run_ports._HANDED_OUT.clear()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("0.0.0.0", first.listen + 2))  # one port of the block is taken
        again = free_ports(vehicles=4, rng=rng)
    assert again.sdk != first.sdk
    assert len({again.sdk, again.listen, again.grpc, again.payload, again.mocap, again.net}) == 6


def test_each_xdist_worker_owns_its_own_slice_below_the_ephemeral_ports(monkeypatch):
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)
    monkeypatch.delenv("PYTEST_XDIST_WORKER_COUNT", raising=False)
    ephemeral = 32768  # port-literal: Linux's first ephemeral port, a limit
    assert worker_slice() == (PORTS_LOW, PORTS_HIGH) and ephemeral >= PORTS_HIGH
    monkeypatch.setenv("PYTEST_XDIST_WORKER_COUNT", "3")
    slices = []
    for i in range(3):
        monkeypatch.setenv("PYTEST_XDIST_WORKER", f"gw{i}")
        slices.append(worker_slice())
        for _ in range(10):  # every block of this worker lies in its slice
            ports = free_ports(vehicles=2)
            assert slices[i][0] <= ports.sdk and ports.net_proxy + 2 <= slices[i][1]
            base = free_port_block(5)
            assert slices[i][0] <= base and base + 5 <= slices[i][1]
    assert slices[0][0] == PORTS_LOW and slices[2][1] <= PORTS_HIGH
    assert all(a[1] <= b[0] for a, b in itertools.pairwise(slices))


def test_one_process_never_gets_the_same_port_twice(monkeypatch):
    """Ports handed out and not bound yet (a module's, at import) are not handed out again.

    With a fresh record: in a worker that already ran many tests the slice may be nearly full,
    and then the oldest half of the record is forgotten, as it should be.
    """
    monkeypatch.setattr(run_ports, "_HANDED_OUT", [])
    blocks = [range(b, b + 20) for b in (free_port_block(20) for _ in range(30))]
    blocks += [range(p.sdk, p.sdk + 200) for p in (free_ports() for _ in range(5))]
    ports = [p for block in blocks for p in block]
    assert len(ports) == len(set(ports))


def write_report(tmp_path, **report):
    (tmp_path / "report.json").write_text(json.dumps(report))
    return RunResult(tmp_path, 1, "the run's output")


def test_assert_passed_names_every_failure_and_the_traceback(tmp_path):
    result = write_report(
        tmp_path,
        passed=False,
        complete=False,
        stop_reason="timeout",
        checks={
            "max_tilt": {"ok": False, "message": "max tilt 52 deg (vehicle2 at t = 31.0 s)"},
            "landed_and_disarmed": {"ok": True, "message": "all landed"},
        },
        companions={
            "vehicle2": {"exit_code": 1, "role": "survey", "traceback": "RuntimeError: boom"}
        },
    )
    with pytest.raises(AssertionError) as info:
        result.assert_passed()
    text = str(info.value)
    assert "incomplete: timeout" in text and "max tilt 52 deg" in text and "boom" in text
    assert "all landed" not in text
    with pytest.raises(AssertionError, match="vehicle2 \\(survey\\) exited 1"):
        result.assert_companions_succeeded()


def test_a_passed_report_passes_and_metrics_read_by_name(tmp_path):
    result = write_report(
        tmp_path, passed=True, complete=True, companions={},
        vehicles={"vehicle1": {"max_tilt": {"value": 12.0, "unit": "deg"}}},
    )  # fmt: skip
    result.assert_passed()
    result.assert_companions_succeeded()
    assert result.metric("vehicles.vehicle1.max_tilt") == 12.0


def test_a_run_without_a_report_says_so_with_its_output(tmp_path):
    with pytest.raises(AssertionError, match=r"(?s)the run wrote no report.*the run's output"):
        _ = RunResult(tmp_path, 2, "the run's output").report


def test_a_taken_grpc_port_is_skipped_for_the_next_free_one():
    """A leftover mavsdk_server on a companion's port would hang it: the runner skips the port."""
    from harness.run.ports import free_tcp_ports

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as held:
        held.bind(("127.0.0.1", 0))
        held.listen()
        taken = held.getsockname()[1]
        ports = free_tcp_ports(taken, 2)
    assert taken not in ports and len(set(ports)) == 2 and min(ports) > taken
