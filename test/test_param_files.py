# SPDX-License-Identifier: Apache-2.0
"""Each default, range and description is written once, in a params dataclass: every params/*.yaml file is
generated from them (`python -m swir_tracker_ros.param_files`), and every params dataclass of the package
reaches a params file (at its top level or nested)."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import typing

import pytest
import yaml
from conftest import REPO

import swir_tracker_ros
from swir_tracker_ros.nodes.param_docs import params_yaml
from swir_tracker_ros.param_files import params_files
from swir_tracker_ros.paramfield import flat_fields

FILES = params_files()
# Parameter dataclasses that are no node's or command's parameters: the core builds them itself.
INTERNAL = {"AdaptiveNoiseParams"}  # kalman.adaptive: its windows are fixed by the tracking variant


@pytest.mark.parametrize("pf", FILES, ids=[pf.path for pf in FILES])
def test_params_file_is_the_generated_one(pf) -> None:
    assert (REPO / pf.path).read_text() == params_yaml(pf), (
        f"{pf.path} differs from its dataclasses; run `.venv/bin/python -m swir_tracker_ros.param_files`")


def _flatten(mapping: dict, prefix: str = "") -> dict:
    out = {}
    for key, value in mapping.items():
        if isinstance(value, dict) and not key.endswith("_overrides"):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[prefix + key] = value
    return out


@pytest.mark.parametrize("pf", FILES, ids=[pf.path for pf in FILES])
def test_params_file_loads_back_to_the_defaults(pf) -> None:
    doc = yaml.safe_load((REPO / pf.path).read_text())[pf.node]
    values = _flatten(doc["ros__parameters"] if pf.ros_parameters else doc)
    defaults = {}
    for block, classes, _ in pf.sections:
        prefix = f"{block}." if block else ""
        for cls in classes if isinstance(classes, tuple) else (classes,):
            defaults.update({name: default for name, _, default in flat_fields(cls, prefix)})
    assert values == defaults


def _params_dataclasses() -> set[type]:
    """Every dataclass of the package whose fields all carry the `doc` metadata and that has `validate()`."""
    found = set()
    for info in pkgutil.walk_packages(swir_tracker_ros.__path__, "swir_tracker_ros."):
        if info.name.endswith("__main__"):
            continue
        module = importlib.import_module(info.name)
        for obj in vars(module).values():
            if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and obj.__module__ == module.__name__ \
                    and hasattr(obj, "validate") and dataclasses.fields(obj) \
                    and all("doc" in f.metadata for f in dataclasses.fields(obj)):
                found.add(obj)
    return found


def _reachable(cls: type) -> set[type]:
    """cls and every params dataclass its fields may hold (a union's members, a base class's subclasses:
    the base filters' Params)."""
    out = {cls}
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        for kind in (hints[f.name], *typing.get_args(hints[f.name])):
            if dataclasses.is_dataclass(kind):
                out |= _reachable(kind)
    for sub in cls.__subclasses__():
        out |= _reachable(sub)
    return out


def _section_classes(pf) -> list[type]:
    """The params classes of a file's sections (a section may hold an instance: a named configuration)."""
    return [c if isinstance(c, type) else type(c) for _, classes, _ in pf.sections
            for c in (classes if isinstance(classes, tuple) else (classes,))]


def test_every_params_dataclass_is_in_a_params_file() -> None:
    covered = set().union(*(_reachable(cls) for pf in FILES for cls in _section_classes(pf)))
    missing = {c.__qualname__ for c in _params_dataclasses() - covered} - INTERNAL
    assert not missing, f"params dataclasses without a generated params file: {sorted(missing)}"
    assert len(covered) >= 9  # tracker node + core (3), positioner, acquisition (2), scene_camera, demo
