# SPDX-License-Identifier: Apache-2.0
"""The parameter contract: field helper, validation and flattening of parameter dataclasses (ROS-free).

Metadata contract: docs/interfaces.md "Parameters". `nodes/ros_params.py` declares the same dataclasses as ROS
parameters and validates them with `validate_params`.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import field
from typing import Any


def param(default: Any, doc: str, lo: float | None = None, hi: float | None = None, **extra: Any) -> Any:
    """A dataclass field with `metadata={"doc": doc, "min": lo, "max": hi, **extra}` (None bounds left out).

    `extra` carries the other contract keys, e.g. `choices=(...)` or `read_only=True`. A list or dict
    default is copied per instance.
    """
    meta: dict[str, Any] = {"doc": doc, **extra}
    if lo is not None:
        meta["min"] = lo
    if hi is not None:
        meta["max"] = hi
    if isinstance(default, (list, dict)):
        return field(default_factory=lambda: type(default)(default), metadata=meta)
    return field(default=default, metadata=meta)


def nested(factory: Any, doc: str) -> Any:
    """A dataclass field holding a nested parameter dataclass (a layer's or a policy's Params), built by
    `factory` per instance, with `metadata={"doc": doc}`."""
    return field(default_factory=factory, metadata={"doc": doc})


_SCALAR_TYPES: dict[Any, tuple[type, ...]] = {str: (str,), int: (int,), float: (int, float), bool: (bool,)}


def _allows_none(kind: Any) -> bool:
    """Whether an annotation admits None (`X | None`): a policy a configuration may leave out."""
    return type(None) in typing.get_args(kind)


def validate_params(params: Any, prefix: str = "") -> None:
    """The one ROS-free check of a parameter dataclass (docs/interfaces.md "Parameters").

    Every field must have its annotated type (an int is accepted for a float), be finite, lie within its
    metadata `min` / `max` and be one of its `choices`; a field holding a parameter dataclass is checked
    recursively with the prefix `<name>.`, as its ROS parameters are named (its runtime class: a field may
    take one of several Params classes, or None where the annotation admits it). Each level's own
    cross-field rule, a method `check()` if it has one, runs after its fields. Raises `ParameterError`
    naming the parameter (`base.padding`) and the value.
    """
    from swir_tracker_ros.errors import ParameterError

    hints = typing.get_type_hints(type(params))
    for f in dataclasses.fields(params):
        value, meta, name = getattr(params, f.name), f.metadata, prefix + f.name
        kind = hints[f.name]
        options = typing.get_args(kind)
        nested = dataclasses.is_dataclass(kind) or any(dataclasses.is_dataclass(a) for a in options)
        if nested:
            if value is None and _allows_none(kind):
                continue
            allowed = (kind,) if dataclasses.is_dataclass(kind) else tuple(
                a for a in options if dataclasses.is_dataclass(a))
            if not isinstance(value, allowed):
                names = " or ".join(a.__name__ for a in allowed)
                raise ParameterError(f"parameter {name} must be a {names}, got {value!r}")
            validate_params(value, name + ".")
            continue
        wrong_bool = isinstance(value, bool) and kind is not bool
        if kind in _SCALAR_TYPES and (wrong_bool or not isinstance(value, _SCALAR_TYPES[kind])):
            raise ParameterError(f"parameter {name} = {value!r} has the wrong type; expected {kind.__name__}")
        values = value if isinstance(value, (list, tuple)) else [value]
        for v in values:
            if isinstance(v, float) and not math.isfinite(v):
                raise ParameterError(f"parameter {name} must be finite, got {value!r}")
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                if "min" in meta and v < meta["min"]:
                    raise ParameterError(f"parameter {name} = {value!r} is below its minimum {meta['min']}")
                if "max" in meta and v > meta["max"]:
                    raise ParameterError(f"parameter {name} = {value!r} is above its maximum {meta['max']}")
        if "choices" in meta and value not in meta["choices"]:
            raise ParameterError(f"parameter {name} = {value!r} is not one of {list(meta['choices'])}")
    check = getattr(params, "check", None)
    if callable(check):
        check()


def as_instance(params: Any) -> Any:
    """A parameter dataclass instance: `params` itself, or its class's default instance."""
    return params() if isinstance(params, type) else params


def flat_fields(params: Any, prefix: str = "") -> list[tuple[str, dataclasses.Field, Any]]:
    """(dotted name, field, value) of every leaf parameter of a parameter dataclass instance (a class: its
    default instance), recursing into the nested Params it holds; a policy left out (None) has none."""
    obj = as_instance(params)
    out: list[tuple[str, dataclasses.Field, Any]] = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out += flat_fields(value, prefix + f.name + ".")
        elif value is not None:
            out.append((prefix + f.name, f, value))
    return out


def leaf_type(params: Any, dotted: str) -> Any:
    """Annotated type of the leaf field `a.b.c` of a parameter dataclass instance (through the nested
    Params it holds)."""
    head, _, rest = dotted.partition(".")
    if rest:
        return leaf_type(getattr(params, head), rest)
    return typing.get_type_hints(type(params))[head]


def rebuild(params: Any, values: dict[str, Any]) -> Any:
    """A copy of the parameter dataclass instance `params` with the dotted leaf `values` replaced (the
    nested Params keep their classes)."""
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(params):
        current = getattr(params, f.name)
        if dataclasses.is_dataclass(current):
            head = f.name + "."
            sub = {k[len(head):]: v for k, v in values.items() if k.startswith(head)}
            kwargs[f.name] = rebuild(current, sub)
        elif f.name in values:
            kwargs[f.name] = values[f.name]
    return dataclasses.replace(params, **kwargs)
