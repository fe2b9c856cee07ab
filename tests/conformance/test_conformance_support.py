"""The conformance report's rule: one miss fails one test, the checks it left unreached skip."""

from __future__ import annotations

import pytest
from conformance_support import Run

OK = {"ok": True}
FAILED = {"ok": False, "error": "ActionError: DENIED"}


def _run(**data) -> Run:
    return Run("classic", {"stage": "done", "checks": {}, **data}, "logs/")


def test_a_passed_check_returns_its_values():
    assert _run(checks={"arm": {"ok": True, "armed": True}}).check("arm")["armed"] is True


def test_a_failed_check_fails_its_test():
    run = _run(checks={"arm": FAILED}, aborted_groups={"action": {"error": "x", "at_check": "arm"}})
    with pytest.raises(pytest.fail.Exception, match="'arm' failed"):
        run.check("arm")
    assert run.incomplete() is None  # the failed check's test reports it, nobody else


def test_checks_after_a_failed_check_are_skipped_and_point_at_it():
    run = _run(checks={"arm": FAILED}, aborted_groups={"action": {"error": "x", "at_check": "arm"}})
    with pytest.raises(pytest.skip.Exception, match="stopped at failed check 'arm'"):
        run.check("takeoff")


def test_a_client_that_stopped_skips_the_rest_and_fails_the_completeness_test():
    run = _run(stage="telemetry_attitude", error="SimTimeout: no attitude", checks={"x": OK})
    with pytest.raises(pytest.skip.Exception, match="test_client_run_completes"):
        run.check("param_get")
    assert "no attitude" in run.incomplete()


def test_a_group_that_failed_between_checks_is_reported_by_the_completeness_test():
    run = _run(
        checks={"a": OK}, aborted_groups={"mission": {"error": "KeyError", "at_check": None}}
    )
    with pytest.raises(pytest.skip.Exception, match="between checks"):
        run.check("mission_upload")
    assert "mission" in run.incomplete()


def test_a_check_that_nothing_explains_fails():
    """A finished run without aborts that lacks a check: a bug in the client or the test."""
    with pytest.raises(pytest.fail.Exception, match="did not run"):
        _run(checks={"a": OK}).check("misspelled")
    assert _run().incomplete() is None
