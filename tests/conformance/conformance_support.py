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
        """The values check ``name`` recorded; fails the test if it failed.

        A check that did not run is skipped when a failure that another test reports explains
        it (its group stopped at a failed check, or the client stopped: one miss fails one test,
        not every check after it), and fails the test otherwise (nothing explains it).
        """
        checks = self.data.get("checks", {})
        found = checks.get(name)
        if found is None:
            reason = self.stop_reason()
            where = (
                f"stage={self.data.get('stage')} error={self.data.get('error')} "
                f"aborted={self.data.get('aborted_groups')} (client logs in {self.log})"
            )
            if reason is not None:
                pytest.skip(f"[{self.api}] check {name!r} not reached: {reason}; {where}")
            pytest.fail(f"[{self.api}] check {name!r} did not run: {where}")
        if not found["ok"]:
            pytest.fail(f"[{self.api}] check {name!r} failed: {json.dumps(found, default=str)}")
        return found

    def stop_reason(self) -> str | None:
        """Why the client skipped checks, as the failing test that reports it; None: it did not.

        Checks are skipped when a group stopped (at a failed check: that check's test fails;
        between checks: :meth:`incomplete` fails) or when the client did not finish.
        """
        reasons = [
            f"group {group!r} stopped at failed check {at!r}"
            if at
            else f"group {group!r} stopped between checks (test_client_run_completes)"
            for group, at in self._stopped_groups().items()
        ]
        if not self._finished():
            reasons.append(
                f"the client stopped at stage {self.data.get('stage')!r} "
                "(test_client_run_completes)"
            )
        return "; ".join(reasons) or None

    def incomplete(self) -> str | None:
        """What no check's test reports: the client did not finish, or a group failed between
        checks. None when every failure of the run is a failed check's."""
        problems = []
        if not self._finished():
            problems.append(
                f"stopped at stage {self.data.get('stage')!r}: {self.data.get('error')}; "
                f"{self.data.get('_describe', '')}"
            )
        notes = self.data.get("aborted_groups", {})
        for group, at in self._stopped_groups().items():
            if not at:
                problems.append(f"group {group!r} failed between checks: {notes[group]}")
        return "\n".join(problems) or None

    def _finished(self) -> bool:
        """The client reached its last stage without an error."""
        return self.data.get("stage") == "done" and not self.data.get("error")

    def _stopped_groups(self) -> dict[str, str | None]:
        """Each group that stopped -> the failed check it stopped at (None: between checks)."""
        notes = self.data.get("aborted_groups", {})
        return {group: note.get("at_check") for group, note in notes.items()}


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
