"""Running conformance clients and reading their check logs.

A conformance client (``tests/conformance/clients``) records named checks in its JSON report
(``clients/_conformance.py``); :func:`check` returns one of them to a test, or fails the test
with the check's error, or with the stage the client reached if the check never ran.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import pytest
from e2e_support import Ports, run_client

CLIENTS_DIR = Path(__file__).resolve().parent / "clients"


@dataclass(frozen=True)
class Run:
    """The report of one conformance client run."""

    api: str
    data: dict
    log: str
    """Where the client's stdout and stderr are, for failure messages."""

    def check(self, name: str) -> dict:
        """The values check ``name`` recorded; fails the test if it failed or did not run."""
        checks = self.data.get("checks", {})
        found = checks.get(name)
        if found is None:
            pytest.fail(
                f"[{self.api}] check {name!r} did not run: stage={self.data.get('stage')} "
                f"error={self.data.get('error')} aborted={self.data.get('aborted_groups')} "
                f"(client logs in {self.log})"
            )
        if not found["ok"]:
            pytest.fail(f"[{self.api}] check {name!r} failed: {json.dumps(found, default=str)}")
        return found


def run_conformance_client(
    script: str,
    api: str,
    ports: Ports,
    log_dir: Path,
    extra: list[str],
    clock: Path,
    timeout_sim_s: float,
) -> Run:
    """Run ``clients/<script>`` with ``--api`` against vehicle 0 of ``ports`` (whose simulation
    clock file is ``clock``), within ``timeout_sim_s`` simulated seconds."""
    args = ["--api", api, "--url", ports.url(), *extra]
    grpc_port = None
    if api == "classic":
        args += ["--grpc-port", str(ports.grpc)]
        grpc_port = ports.grpc
    result = run_client(
        str(CLIENTS_DIR / script),
        args,
        log_dir,
        clock=clock,
        timeout_sim_s=timeout_sim_s,
        grpc_port=grpc_port,
    )
    if not result.data:
        pytest.fail(result.describe())
    return Run(api, result.data | {"_describe": result.describe()}, str(log_dir))
