"""The package boundaries of DESIGN.md hold: companion and autopilot never import the simulator."""

from __future__ import annotations

import logging
from pathlib import Path

from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]


def test_import_contracts_are_kept(monkeypatch):
    """All import-linter contracts in pyproject.toml pass (companion/autopilot_emu/sitl limits)."""
    monkeypatch.chdir(ROOT)
    loggers = [
        logger
        for logger in logging.root.manager.loggerDict.values()
        if isinstance(logger, logging.Logger) and not logger.disabled
    ]
    try:
        assert lint_imports(config_filename=str(ROOT / "pyproject.toml")) == 0
    finally:
        # import-linter configures logging with disable_existing_loggers: re-enable ours, or the
        # tests that run after this one would see no log records (caplog).
        for logger in loggers:
            logger.disabled = False


def test_contracts_cover_the_design_boundaries():
    """The contracts forbid what DESIGN.md forbids (so they cannot be weakened silently)."""
    text = (ROOT / "pyproject.toml").read_text()
    assert 'source_modules = ["companion"]' in text
    assert 'forbidden_modules = ["sitl", "autopilot_emu", "harness"]' in text
    assert 'source_modules = ["autopilot_emu"]' in text
    assert 'forbidden_modules = ["sitl", "companion", "worlds", "compression", "harness"]' in text
