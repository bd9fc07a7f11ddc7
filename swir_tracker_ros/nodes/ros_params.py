# SPDX-License-Identifier: Apache-2.0
"""Declare a parameter dataclass as described, range-checked ROS parameters (docs/interfaces.md).

Nested parameter dataclasses become dotted names (`tracker.base.padding`); validation is the ROS-free
`paramfield.validate_params`. A params class declares its defaults; an instance (a named configuration)
declares its own values as the defaults, its nested Params keeping their classes.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Callable
from typing import Any, TypeVar

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterException,
)
from rclpy.node import Node
from rclpy.parameter import Parameter

from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import as_instance, flat_fields, leaf_type, rebuild, validate_params

P = TypeVar("P")
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1

_PTYPES = {
    float: ParameterType.PARAMETER_DOUBLE,
    int: ParameterType.PARAMETER_INTEGER,
    bool: ParameterType.PARAMETER_BOOL,
    str: ParameterType.PARAMETER_STRING,
    list: ParameterType.PARAMETER_DOUBLE_ARRAY,
}


def _base_type(annotation: Any) -> type:
    """float / int / bool / str / list for the field types the contract allows (list[float], tuples too)."""
    origin = typing.get_origin(annotation)
    if origin in (list, tuple):
        return list
    if annotation in _PTYPES:
        return annotation
    raise ParameterError(f"parameter field type {annotation!r} is not float, int, bool, str or list[float]")


def _coerce(kind: type, name: str, value: Any) -> Any:
    """Python value of the dataclass field type from a ROS parameter value."""
    if kind is list and value is None:
        return []  # an unset (read-only, empty) array parameter
    try:
        if kind is float:
            return float(value)
        if kind is int and not isinstance(value, bool):
            return int(value)
        if kind is bool and isinstance(value, bool):
            return value
        if kind is str and isinstance(value, str):
            return value
        if kind is list:
            return [float(v) for v in value]
    except (TypeError, ValueError):
        pass
    raise ParameterError(f"parameter {name} must be of type {kind.__name__}, got {value!r}")


def describe(f: dataclasses.Field, kind: type, name: str) -> ParameterDescriptor:
    """The ParameterDescriptor of one field: description (doc + choices), type, range, read-only flag."""
    meta = f.metadata
    text = str(meta.get("doc", ""))
    if "choices" in meta:
        text += f" One of: {', '.join(map(str, meta['choices']))}."
    desc = ParameterDescriptor(name=name, type=_PTYPES[kind], description=text,
                               read_only=bool(meta.get("read_only", False)))
    if "choices" in meta:
        desc.additional_constraints = f"one of {list(meta['choices'])}"
    has_range = "min" in meta or "max" in meta
    if kind is float and has_range:
        lo, hi = float(meta.get("min", -math.inf)), float(meta.get("max", math.inf))
        desc.floating_point_range = [FloatingPointRange(from_value=lo, to_value=hi, step=0.0)]
    elif kind is int and has_range:
        desc.integer_range = [IntegerRange(
            from_value=int(meta.get("min", INT64_MIN)), to_value=int(meta.get("max", INT64_MAX)), step=0)]
    return desc


def _build(template: P, values: dict[str, Any], prefix: str) -> P:
    """`template` with the (dotted) field values, validated by metadata and by its own `validate()`."""
    name = prefix or type(template).__name__
    try:
        params = rebuild(template, values)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"parameters {name} cannot be built: {exc}") from exc
    validate_params(params, prefix)
    validate = getattr(params, "validate", None)
    if callable(validate):
        try:
            validate()
        except ParameterError:
            raise
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"parameters {name} are invalid: {exc}") from exc
    return params


def _widen_integer_overrides(node: Node, name: str, kind: type) -> None:
    """Let `-p x:=20` or a YAML `[1, 2]` set a float / list[float] parameter: integers become doubles.

    rclpy keeps command-line and params-file overrides in `Node._parameter_overrides` until declaration.
    """
    overrides = getattr(node, "_parameter_overrides", None)
    param = overrides.get(name) if isinstance(overrides, dict) else None
    if param is None:
        return
    if kind is float and param.type_ == Parameter.Type.INTEGER:
        overrides[name] = Parameter(name, Parameter.Type.DOUBLE, float(param.value))
    elif kind is list and param.type_ == Parameter.Type.INTEGER_ARRAY:
        overrides[name] = Parameter(name, Parameter.Type.DOUBLE_ARRAY, [float(v) for v in param.value])


def bind_parameters(node: Node, cls: type[P] | P, *, prefix: str = "",
                    on_change: Callable[[P], None] | None = None,
                    vet: Callable[[P], str | None] | None = None) -> P:
    """Declare every field of the params `cls` (a class: its defaults; an instance: its values) as
    `<prefix><field>`, read and validate the values.

    Overrides from `--params-file` / `--ros-args -p` apply at declaration. A wrong type, a value out of
    range or a failing `validate()` raises `ParameterError` naming the parameter and the value. After
    start-up, a runtime change is rejected with that sentence as the reason, or with `vet(candidate)`'s
    reason when it gives one (e.g. a network's missing weights); an accepted change calls
    `on_change(new_instance)` after the values are set.
    """
    if not dataclasses.is_dataclass(cls):
        raise ParameterError(f"{cls!r} is not a parameter dataclass")
    template = as_instance(cls)
    # every leaf parameter, nested dataclasses flattened to dotted names (`tracker.base.padding`)
    leaves = flat_fields(template)
    fields = {prefix + dotted: f for dotted, f, _ in leaves}
    local = {prefix + dotted: dotted for dotted, _, _ in leaves}
    defaults = {prefix + dotted: value for dotted, _, value in leaves}
    kinds = {prefix + dotted: _base_type(leaf_type(template, dotted)) for dotted, _, _ in leaves}
    values: dict[str, Any] = {}
    for name, f in fields.items():
        kind = kinds[name]
        default = _coerce(kind, name, defaults[name])
        desc = describe(f, kind, name)
        _widen_integer_overrides(node, name, kind)
        try:
            if kind is list and not default:
                # An empty list has no inferable type: declare by type, then fill in the empty default.
                ptype = Parameter.Type.DOUBLE_ARRAY
                declared = node.declare_parameter(name, ptype, desc).value
                if declared is None and not desc.read_only:
                    node.set_parameters([Parameter(name, ptype, [])])
                declared = [] if declared is None else declared
            else:
                declared = node.declare_parameter(name, default, desc).value
        except (InvalidParameterTypeException, InvalidParameterValueException, ParameterException) as exc:
            raise ParameterError(f"parameter {name} is invalid: {exc}") from exc
        values[local[name]] = _coerce(kind, name, declared)
    current = _build(template, values, prefix)

    def current_values() -> dict[str, Any]:
        return {local[n]: _coerce(kinds[n], n, node.get_parameter(n).value) for n in fields}

    def on_set(params: list[Parameter]) -> SetParametersResult:
        mine = [p for p in params if p.name in fields]
        if not mine:
            return SetParametersResult(successful=True)
        try:
            candidate = current_values()
            for p in mine:
                candidate[local[p.name]] = _coerce(kinds[p.name], p.name, p.value)
            built = _build(template, candidate, prefix)
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        reason = vet(built) if vet is not None else None
        return SetParametersResult(successful=not reason, reason=reason or "")

    def post_set(params: list[Parameter]) -> None:
        if on_change is not None and any(p.name in fields for p in params):
            on_change(_build(template, current_values(), prefix))

    node.add_on_set_parameters_callback(on_set)
    node.add_post_set_parameters_callback(post_set)
    return current
