"""Validating a YAML file against a pydantic model, with errors that name file, line and field.

Worlds (``worlds.schema``) and scenarios (``harness.scenarios.spec``) are YAML files a person
writes;
a mistake must be reported where it is (``offshore.yaml:12: spill_count: unknown key``) before
anything starts. YAML would silently keep the last of two equal keys: that is an error too.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError


def node_at(root: yaml.Node, loc: tuple[Any, ...]) -> tuple[yaml.Node, bool]:
    """The YAML node at pydantic's ``loc``, and whether it exists (else the deepest parent)."""
    node = root
    for i, part in enumerate(loc):
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                if key.value == str(part):
                    node = key if i == len(loc) - 1 else value
                    break
            else:
                return node, False
        elif (
            isinstance(node, yaml.SequenceNode) and isinstance(part, int) and part < len(node.value)
        ):
            node = node.value[part]
        else:
            return node, False
    return node, True


def duplicate_keys(node: yaml.Node) -> list[yaml.Node]:
    """Key nodes repeating an earlier key of their mapping (YAML would silently keep the last)."""
    out: list[yaml.Node] = []
    if isinstance(node, yaml.MappingNode):
        seen = set()
        for key, value in node.value:
            if key.value in seen:
                out.append(key)
            seen.add(key.value)
            out += duplicate_keys(value)
    elif isinstance(node, yaml.SequenceNode):
        for item in node.value:
            out += duplicate_keys(item)
    return out


def validate_yaml(
    text: str,
    source: str,
    model_of: Callable[[dict[str, Any], yaml.Node], type[BaseModel]],
    error: type[ValueError],
    shape_hint: str,
    hint: Callable[[dict[str, Any]], str] | None = None,
) -> BaseModel:
    """Parse YAML ``text`` and validate it with the model ``model_of(data, root)`` picks.

    Args:
        text: the file's content.
        source: how errors name the file (its path).
        model_of: the pydantic model for this mapping (may raise ``error`` itself).
        error: the exception raised, with one ``source:line: field: problem`` line per problem.
        shape_hint: what the top level must be, for files that are not a mapping.
        hint: more words for one pydantic error (``ErrorDetails``), appended to its problem,
            e.g. the scenario loader's "; did you mean count?" for an unknown key.
    """
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f":{mark.line + 1}" if mark is not None else ""
        raise error(f"{source}{line}: not valid YAML: {exc}") from exc
    if not isinstance(data, dict) or root is None:
        raise error(f"{source}:1: {shape_hint}")
    duplicates = duplicate_keys(root)
    if duplicates:
        raise error(
            "\n".join(
                f"{source}:{k.start_mark.line + 1}: {k.value}: duplicate key" for k in duplicates
            )
        )
    model = model_of(data, root)
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        lines = []
        for err in exc.errors():
            loc = tuple(err["loc"])
            node, _ = node_at(root, loc)
            field = ".".join(str(p) for p in loc) or "<top>"
            msg = err["msg"]
            if err["type"] == "extra_forbidden":
                msg = "unknown key"
            elif err["type"] == "missing":
                msg = "missing field"
            if hint is not None:
                msg += hint(dict(err))
            lines.append(f"{source}:{node.start_mark.line + 1}: {field}: {msg}")
        raise error("\n".join(lines)) from None
