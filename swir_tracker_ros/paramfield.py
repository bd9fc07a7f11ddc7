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


_SCALAR_TYPES: dict[Any, tuple[type, ...]] = {str: (str,), int: (int,), float: (int, float), bool: (bool,)}


def validate_params(params: Any, prefix: str = "") -> None:
    """The one ROS-free check of a parameter dataclass (docs/interfaces.md "Parameters").

    Every field must have its annotated type (an int is accepted for a float), be finite, lie within its
    metadata `min` / `max` and be one of its `choices`; a field holding a parameter dataclass is checked
    recursively with the prefix `<name>.`, as its ROS parameters are named. Each level's own cross-field
    rule, a method `check()` if it has one, runs after its fields. Raises `ParameterError` naming the
    parameter (`kcf.padding`) and the value.
    """
    from swir_tracker_ros.errors import ParameterError

    hints = typing.get_type_hints(type(params))
    for f in dataclasses.fields(params):
        value, meta, name = getattr(params, f.name), f.metadata, prefix + f.name
        kind = hints[f.name]
        if dataclasses.is_dataclass(kind):
            if not isinstance(value, kind):
                raise ParameterError(f"parameter {name} must be a {kind.__name__}, got {value!r}")
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


def flat_fields(cls: type, prefix: str = "") -> list[tuple[str, dataclasses.Field, Any]]:
    """(dotted name, field, default) of every leaf parameter of `cls`, recursing into nested dataclasses."""
    out: list[tuple[str, dataclasses.Field, Any]] = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        kind = hints[f.name]
        if dataclasses.is_dataclass(kind):
            out += flat_fields(kind, prefix + f.name + ".")
        else:
            factory = f.default_factory
            default = f.default if f.default is not dataclasses.MISSING else factory()  # type: ignore[misc]
            out.append((prefix + f.name, f, default))
    return out
