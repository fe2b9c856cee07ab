"""Fixtures of the MAVSDK conformance suite; the machinery is :mod:`e2e_support`'s.

``tests/e2e`` goes on ``sys.path`` so the suite imports ``e2e_support`` as the e2e modules do.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

E2E_DIR = Path(__file__).resolve().parents[1] / "e2e"
if str(E2E_DIR) not in sys.path:
    sys.path.insert(0, str(E2E_DIR))


@pytest.fixture
def client_logs(tmp_path: Path) -> Path:
    """Where this test's client processes write their stdout and stderr."""
    return tmp_path / "clients"
