"""A role's companion ``args``, checked when the scenario loads against what its program declares.

A companion program module declares the dataclass of its arguments as its module-level
``PARAMS`` (``companion.scripts.coverage``: ``PARAMS = CoverageParams``), the dataclass it reads
``SWARMSITL_PARAMS`` into with ``companion.role_params.params_from_mapping``. The scenario loader
reads the same ``args`` with the same function before anything starts, so that a misspelt key is
one ``swarmsitl run`` error (exit status 2) rather than one traceback per vehicle.

Only a program run as a module can be looked up: a role's ``module:``, or a ``command:`` of the
form ``["{python}", "-m", MODULE, ...]`` (for ``python -m PACKAGE``: ``PACKAGE.__main__``). The
module is found as ``python -m`` in the scenario's folder finds it (that folder first on the
path), and its source is read first: it is imported only when it assigns ``PARAMS`` at its top
level. A program that declares nothing, a script or another command is never imported (its top
level might fly) and its ``args`` pass unchecked.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import json
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, is_dataclass
from pathlib import Path
from typing import Any

from companion.role_params import PARAMS_ATTRIBUTE, UnknownParamsError, params_from_mapping
from harness.options.suggest import did_you_mean

PYTHON_PLACEHOLDER = "{python}"
"""What a role's ``command`` writes for the interpreter running swarmsitl."""


class DeclarationError(ValueError):
    """A module that assigns ``PARAMS`` but cannot be imported, or whose PARAMS is no dataclass."""


@dataclass(frozen=True)
class ArgsProblem:
    """Why a role's ``args`` would stop its program."""

    key: str | None
    """The ``args`` key at fault; None: the ``args`` as a whole (a bad value, not JSON)."""
    message: str


def program_module(
    module: str | None, command: Sequence[str] | None, python: str = PYTHON_PLACEHOLDER
) -> str | None:
    """The module a role's program runs as ``python -m``; None for a script or another command."""
    if module:
        return module
    if command and len(command) >= 3 and command[0] == python and command[1] == "-m":
        return command[2]
    return None


@contextmanager
def _path_first(folder: Path) -> Iterator[None]:
    """``folder`` first on ``sys.path`` for the block (as ``python -m`` run there has its cwd)."""
    entry = str(folder)
    sys.path.insert(0, entry)
    try:
        yield
    finally:
        sys.path.remove(entry)


def _assigns_params(source: str) -> bool:
    """True if the module's top level binds ``PARAMS`` (assignment or ``import ... as PARAMS``)."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return False  # the program reports that itself when it starts
    for node in tree.body:
        if isinstance(node, ast.Assign):
            names = [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names = [node.target.id]
        elif isinstance(node, ast.ImportFrom):
            names = [a.asname or a.name for a in node.names]
        else:
            continue
        if PARAMS_ATTRIBUTE in names:
            return True
    return False


def _declaring_module(name: str) -> str | None:
    """The module ``python -m name`` runs, if its source assigns ``PARAMS``; else None."""
    try:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations is not None:
            name = f"{name}.__main__"  # python -m PACKAGE runs PACKAGE/__main__.py
            spec = importlib.util.find_spec(name)
    except Exception:  # a parent package that fails to import: the program will say so itself
        return None
    if spec is None or not spec.has_location or not str(spec.origin).endswith(".py"):
        return None
    try:
        source = Path(str(spec.origin)).read_text()
    except (OSError, UnicodeDecodeError):
        return None
    return name if _assigns_params(source) else None


def declared_params(module: str, search_dir: Path) -> type | None:
    """The ``PARAMS`` dataclass module ``module`` declares, or None if it declares none.

    Raises:
        DeclarationError: the module assigns ``PARAMS`` but fails to import, or its PARAMS is
            not a dataclass.
    """
    with _path_first(search_dir):
        declaring = _declaring_module(module)
        if declaring is None:
            return None
        try:
            loaded = importlib.import_module(declaring)
        except Exception as exc:  # the program would fail the same way in every process
            raise DeclarationError(
                f"cannot import {declaring} to read its {PARAMS_ATTRIBUTE}: "
                f"{type(exc).__name__}: {exc}"
            ) from exc
    declared = getattr(loaded, PARAMS_ATTRIBUTE, None)
    if declared is None:
        return None
    if not (isinstance(declared, type) and is_dataclass(declared)):
        raise DeclarationError(
            f"{declaring}.{PARAMS_ATTRIBUTE} must be a dataclass (the type of its args), "
            f"got {declared!r}"
        )
    return declared


def check_args(params: type, args: Mapping[str, Any], module: str) -> ArgsProblem | None:
    """What reading ``args`` into ``params`` would raise in the program, or None if nothing.

    ``args`` take the path they take to the program (JSON in ``SWARMSITL_PARAMS``) and are read
    by :func:`companion.role_params.params_from_mapping`, as the program reads them.
    """
    try:
        data = json.loads(json.dumps(dict(args)))
    except (TypeError, ValueError) as exc:
        return ArgsProblem(None, f"not JSON, as {module} reads them: {exc}")
    try:
        params_from_mapping(params, data)
    except UnknownParamsError as exc:
        key = next(k for k in data if k in exc.unknown)
        return ArgsProblem(key, f"unknown argument of {module}{did_you_mean(key, exc.known)}")
    except (TypeError, ValueError) as exc:
        return ArgsProblem(None, f"{module} rejects them: {exc}")
    return None
