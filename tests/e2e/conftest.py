"""Fixtures of the end-to-end tests; the machinery lives in :mod:`e2e_support`."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture
def client_logs(tmp_path: Path) -> Path:
    """Where this test's client processes write their stdout and stderr."""
    return tmp_path / "clients"
