"""Run-level metrics: a role module's ``run_metrics(env, report)``, at every fidelity.

A role's module may define::

    def run_metrics(env: ScenarioEnv, report: dict) -> dict[str, tuple[Any, str]]

which is called once after the run (after the vehicles' and the fleet's metrics, before the
``checks.metrics`` bounds) with the run as the role's first vehicle sees it (``env.params``: the
role's args, ``env.world``, ``env.seed``, ``env.duration_s``, ``env.fleet``) and the report as it
stands. Its ``{name: (value, unit)}`` go to ``report["fleet"]["run"][name]`` as quantities, so
that ``checks.metrics`` (``fleet.run.NAME``) and a sweep's table (column ``fleet.run.NAME``) see
them. A name that two or more roles report is kept per role, under
``report["fleet"]["run"][ROLE][name]`` (``fleet.run.ROLE.NAME``). A ``run_metrics`` that raises,
or returns something else than a mapping of (value, unit) pairs, costs only its own numbers: a
warning names it and the check ``run_metrics`` fails. Script and command roles have no module
and are skipped. docs/swarm.md.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from harness.report.run_report import quantity

if TYPE_CHECKING:
    from companion.scenario_env import ScenarioEnv
    from harness.scenarios.spec import Scenario

HOOK = "run_metrics"
"""Name of the run-level metrics function a role's module may define."""
CHECK = "run_metrics"
"""Name of the check that fails when a role's ``run_metrics`` raised."""


def _call(module: Any, env: ScenarioEnv, report: dict[str, Any]) -> dict[str, tuple[Any, str]]:
    """The module's metrics, checked to be ``{name: (value, unit)}``."""
    out = getattr(module, HOOK)(env, report)
    if not isinstance(out, Mapping):
        raise TypeError(f"returned {type(out).__name__}, not a mapping name -> (value, unit)")
    metrics = {}
    for name, pair in out.items():
        if not isinstance(name, str) or not name or "." in name:
            raise TypeError(f"metric name {name!r}: a non-empty text without dots")
        if not isinstance(pair, tuple | list) or len(pair) != 2:
            raise TypeError(f"{name}: {pair!r} is not a (value, unit) pair")
        metrics[name] = (pair[0], str(pair[1]))
    return metrics


def add_run_metrics(
    report: dict[str, Any], scenario: Scenario, envs: Mapping[str, ScenarioEnv]
) -> None:
    """Call every role module's ``run_metrics``; its numbers to ``report["fleet"]["run"]``.

    ``envs``: the ScenarioEnv of each role's first vehicle (a role without one is skipped).
    Adds the check ``run_metrics`` (failed when one raised) only when some module defines the
    hook; recomputes nothing else (the caller evaluates ``checks.metrics`` and ``passed``).
    """
    results: dict[str, dict[str, tuple[Any, str]]] = {}
    errors: list[str] = []
    for role, spec in scenario.spec.roles.items():
        if spec.module is None or role not in envs:
            continue
        try:
            module = importlib.import_module(spec.module)
        except Exception as exc:  # the run already imported or started it; be safe
            errors.append(f"roles.{role}: cannot import {spec.module}: {exc!r}")
            continue
        if not callable(getattr(module, HOOK, None)):
            continue
        try:
            results[role] = _call(module, envs[role], report)
        except Exception as exc:  # a broken metric must not cost the report
            errors.append(f"roles.{role}: {spec.module}.{HOOK}: {type(exc).__name__}: {exc}")
    if not results and not errors:
        return
    seen: dict[str, int] = {}
    for metrics in results.values():
        for name in metrics:
            seen[name] = seen.get(name, 0) + 1
    run: dict[str, Any] = {}
    for role, metrics in results.items():
        for name, (value, unit) in metrics.items():
            if seen[name] == 1:
                run[name] = quantity(value, unit)
            else:
                run.setdefault(role, {})[name] = quantity(value, unit)
    report.setdefault("fleet", {})["run"] = run
    report.setdefault("warnings", []).extend(errors)
    report.setdefault("checks", {})[CHECK] = {
        "ok": not errors,
        "value": len(errors),
        "message": "; ".join(errors) or f"{len(results)} role(s)' run metrics computed",
    }
