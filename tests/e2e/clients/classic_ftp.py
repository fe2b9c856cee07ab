"""Classic MAVSDK-Python client of the vehicle's MAVLink FTP server (``drone.ftp``).

    python classic_ftp.py --url udpin://0.0.0.0:PORT --grpc-port GRPC \
        --seed-remote /log/seed.bin --seed-local /tmp/seed.bin --work-dir /tmp/ftp

Lists the root and ``/log``; downloads the file the test placed on the vehicle (burst and
plain reads); uploads a file, compares it by CRC-32 (``are_files_identical``, also against a
changed copy); creates a directory, removes the uploaded file; provokes errors (missing file,
existing directory, a path out of the root). Reports every listing, the byte-exactness of the
downloads and the FtpResult names of the errors.
"""

from __future__ import annotations

import os
from pathlib import Path

from _common import Report, classic_main, wait_for, within

UPLOAD_BYTES = 3000
STEP_TIMEOUT_S = 60.0
"""Simulated seconds one FTP call may take."""


def entries(data) -> list[list]:
    """ListDirectoryData -> sorted [name, type, size] lists."""
    return sorted([e.name, str(e.entry_type), e.size_bytes] for e in data.entries)


async def download(drone, remote: str, local_dir: Path, use_burst: bool) -> bytes:
    async def transfer():
        async for _ in drone.ftp.download(remote, str(local_dir), use_burst):
            pass

    local_dir.mkdir(parents=True, exist_ok=True)
    await within(transfer(), STEP_TIMEOUT_S, f"download of {remote}")
    return (local_dir / Path(remote).name).read_bytes()


async def error_of(call) -> str:
    """The FtpResult name a failing ftp call raises ("no error" if it succeeds)."""
    from mavsdk_grpc.ftp import FtpError

    try:
        await within(call, STEP_TIMEOUT_S, "the ftp call")
    except FtpError as exc:
        return str(exc._result.result)
    return "no error"


async def session(args, r: Report) -> None:
    from mavsdk_grpc import System

    drone = System(port=args.grpc_port)
    work = Path(args.work_dir)
    try:
        r.stage("connect")
        await drone.connect(system_address=args.url)
        await wait_for(drone.core.connection_state(), lambda s: s.is_connected, 120, "connection")
        ftp = drone.ftp

        r.stage("list")
        r["list_root"] = entries(await within(ftp.list_directory("/"), STEP_TIMEOUT_S, "list /"))
        r["list_log"] = entries(
            await within(ftp.list_directory("/log"), STEP_TIMEOUT_S, "list /log")
        )

        r.stage("download")
        seed = Path(args.seed_local).read_bytes()
        burst = await download(drone, args.seed_remote, work / "burst", use_burst=True)
        plain = await download(drone, args.seed_remote, work / "plain", use_burst=False)
        r["download_burst_identical"] = burst == seed
        r["download_plain_identical"] = plain == seed
        r["download_sizes"] = [len(burst), len(plain), len(seed)]

        r.stage("upload")
        local = work / "upload.bin"
        local.write_bytes(os.urandom(UPLOAD_BYTES))
        async for _ in ftp.upload(str(local), "/log"):
            pass
        r["identical_after_upload"] = await within(
            ftp.are_files_identical(str(local), "/log/upload.bin"), STEP_TIMEOUT_S, "a CRC"
        )
        changed = work / "changed.bin"
        # Flip the first byte's bits: replacing it with a fixed byte left the copy unchanged
        # whenever the random file began with that byte (1 run in 256, seen in CI).
        original = local.read_bytes()
        changed.write_bytes(bytes([original[0] ^ 0xFF]) + original[1:])
        r["identical_to_changed_copy"] = await within(
            ftp.are_files_identical(str(changed), "/log/upload.bin"), STEP_TIMEOUT_S, "a CRC"
        )

        r.stage("directories")
        await within(ftp.create_directory("/log/flight1"), STEP_TIMEOUT_S, "mkdir")
        r["list_log_after_upload"] = entries(
            await within(ftp.list_directory("/log"), STEP_TIMEOUT_S, "list /log")
        )
        await within(ftp.remove_file("/log/upload.bin"), STEP_TIMEOUT_S, "rm")
        r["list_log_after_remove"] = entries(
            await within(ftp.list_directory("/log"), STEP_TIMEOUT_S, "list /log")
        )

        r.stage("errors")
        r["errors"] = {
            "remove_missing": await error_of(ftp.remove_file("/log/nope.bin")),
            "create_existing": await error_of(ftp.create_directory("/log/flight1")),
            "list_outside": await error_of(ftp.list_directory("/..")),
            "remove_outside": await error_of(ftp.remove_file("../outside.txt")),
        }
        r.stage("done")
    finally:
        drone._stop_mavsdk_server()


def _options(ap) -> None:
    ap.add_argument("--seed-remote", required=True)
    ap.add_argument("--seed-local", required=True)
    ap.add_argument("--work-dir", required=True)


def main() -> None:
    classic_main(session, _options)


if __name__ == "__main__":
    main()
