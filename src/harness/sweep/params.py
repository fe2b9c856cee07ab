"""Dotted scenario parameters (``fleet.0.count``, ``roles.survey.args.speed_m_s``).

A sweep names a scenario value by its path in the scenario YAML: mapping keys and list indices
(integers) joined by dots. A path must lead to a value the file has, or to a field the scenario
schema defines (``swarm.step_hz`` when the file leaves the whole ``swarm`` section at its
defaults); free-form mappings (a role's ``args``, ``env``, ``params``) only take keys the file
already has, so that a typo is an error instead of a value no program reads.
"""

from __future__ import annotations

import copy
import types
import typing
from typing import Any

from pydantic import BaseModel

from harness.options.suggest import did_you_mean
from harness.scenarios.spec import ScenarioSpec


class ParameterError(ValueError):
    """A dotted parameter that names nothing in the scenario."""


def _unwrap(annotation: Any) -> Any:
    """``X | None`` -> ``X`` (the one non-None member of a union), else unchanged."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        members = [a for a in typing.get_args(annotation) if a is not type(None)]
        models = [a for a in members if _is_model(a) or typing.get_origin(a) in (list, dict)]
        if len(models) == 1:
            return models[0]
    if origin is typing.Annotated:
        return _unwrap(typing.get_args(annotation)[0])
    return annotation


def _is_model(annotation: Any) -> bool:
    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def _child(shape: Any, part: str) -> Any:
    """The schema shape below ``part`` of ``shape`` (a model, ``list[X]``, ``dict[str, X]``)."""
    shape = _unwrap(shape)
    if _is_model(shape):
        field = shape.model_fields.get(part)
        return None if field is None else field.annotation
    origin = typing.get_origin(shape)
    if origin in (list, dict):
        args = typing.get_args(shape)
        return args[-1] if args else None
    return None


def _schema_keys(shape: Any) -> list[str]:
    shape = _unwrap(shape)
    return list(shape.model_fields) if _is_model(shape) else []


def set_parameter(data: dict[str, Any], dotted: str, value: Any) -> None:
    """Set the scenario value at ``dotted`` in the parsed YAML ``data`` (in place).

    Raises ParameterError naming the first part of the path that leads nowhere, with the close
    matches among the keys there (the file's and the schema's).
    """
    parts = dotted.split(".")
    if not dotted or any(not p for p in parts):
        raise ParameterError(f"{dotted!r}: not a dotted parameter name (e.g. fleet.0.count)")
    node: Any = data
    shape: Any = ScenarioSpec
    for k, part in enumerate(parts):
        where = ".".join(parts[:k]) or "the scenario"
        last = k == len(parts) - 1
        if isinstance(node, list):
            try:
                index = int(part)
            except ValueError:
                raise ParameterError(
                    f"{dotted}: {where} is a list; {part!r} is not an index (0..{len(node) - 1})"
                ) from None
            if not 0 <= index < len(node):
                raise ParameterError(f"{dotted}: {where} has {len(node)} entries; no index {index}")
            if last:
                node[index] = value
                return
            node, shape = node[index], _child(shape, part)
            continue
        if not isinstance(node, dict):
            raise ParameterError(f"{dotted}: {where} is a value ({node!r}), not a section")
        schema_keys = _schema_keys(shape)
        if part not in node and part not in schema_keys:
            keys = sorted(set(node) | set(schema_keys))
            hint = did_you_mean(part, keys, listing="there")
            raise ParameterError(f"{dotted}: {where} has no {part!r}{hint}")
        if last:
            node[part] = value
            return
        child = _child(shape, part)
        if part not in node or node[part] is None:
            if not (_is_model(_unwrap(child)) or typing.get_origin(_unwrap(child)) is dict):
                raise ParameterError(f"{dotted}: {where}.{part} is not set in the scenario file")
            node[part] = {}
        node, shape = node[part], child


def apply_parameters(data: dict[str, Any], values: dict[str, Any]) -> dict[str, Any]:
    """A copy of the parsed scenario YAML with every dotted parameter set."""
    out = copy.deepcopy(data)
    for dotted, value in values.items():
        set_parameter(out, dotted, value)
    return out
