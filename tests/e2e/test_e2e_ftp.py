"""MAVLink FTP with classic MAVSDK-Python (``drone.ftp`` through a real ``mavsdk_server``).

One ``swarmsitl up`` vehicle; the test places a file in the vehicle's FTP root
(``<run dir>/vehicle1/fs``) and a file next to it, outside the root, then runs
``clients/classic_ftp.py`` and checks its report against what is on disk afterwards.
"""

from __future__ import annotations

import os

import pytest
from e2e_support import module_ports, run_client, running_swarm

pytestmark = pytest.mark.e2e

PORTS = module_ports()
SEED_BYTES = 80_000
"""Size of the file downloaded: three bursts (35 000 bytes each at most) of 239-byte packets."""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The client's report and the run directory, after the swarm stopped."""
    base = tmp_path_factory.mktemp("ftp")
    out = base / "run"
    seed = os.urandom(SEED_BYTES)
    (base / "seed.bin").write_bytes(seed)
    with running_swarm(1, PORTS, out) as swarm:
        root = swarm.out / "vehicle1" / "fs"
        assert (root / "log").is_dir(), "the vehicle's FTP root was not created"
        (root / "log" / "seed.bin").write_bytes(seed)
        (root.parent / "outside.txt").write_bytes(b"not the vehicle's")
        result = run_client(
            "classic_ftp.py",
            [
                "--url",
                PORTS.url(),
                "--grpc-port",
                str(PORTS.grpc),
                "--seed-remote",
                "/log/seed.bin",
                "--seed-local",
                str(base / "seed.bin"),
                "--work-dir",
                str(base / "client"),
            ],
            base / "client-logs",
            clock=swarm.clock,
            grpc_port=PORTS.grpc,
        )
    assert result.ok, result.describe()
    return result.data, root


def test_list_directory_shows_the_root_and_log(report):
    data, _ = report
    assert ["log", "DIRECTORY", 0] in data["list_root"]
    assert data["list_log"] == [["seed.bin", "FILE", SEED_BYTES]]


def test_download_burst_and_plain_are_byte_exact(report):
    data, _ = report
    assert data["download_sizes"] == [SEED_BYTES] * 3
    assert data["download_burst_identical"]
    assert data["download_plain_identical"]


def test_upload_then_crc_compare(report):
    """are_files_identical compares MAVSDK's local CRC-32 with the vehicle's CalcFileCRC32."""
    data, _ = report
    assert data["identical_after_upload"] is True
    assert data["identical_to_changed_copy"] is False


def test_create_directory_and_remove_file(report):
    data, root = report
    after_upload = {name: kind for name, kind, _ in data["list_log_after_upload"]}
    assert after_upload == {"seed.bin": "FILE", "upload.bin": "FILE", "flight1": "DIRECTORY"}
    after_remove = {name for name, _, _ in data["list_log_after_remove"]}
    assert after_remove == {"seed.bin", "flight1"}
    assert (root / "log" / "flight1").is_dir()
    assert not (root / "log" / "upload.bin").exists()


def test_errors_are_reported_with_px4s_nak_codes(report):
    data, root = report
    assert data["errors"] == {
        "remove_missing": "FILE_DOES_NOT_EXIST",
        "create_existing": "FILE_EXISTS",
        "list_outside": "FILE_PROTECTED",
        "remove_outside": "FILE_PROTECTED",
    }
    assert (root.parent / "outside.txt").read_bytes() == b"not the vehicle's"
