# SPDX-License-Identifier: Apache-2.0
"""The tracking core's parameter contract: every params dataclass, its YAML block and its docs table agree."""

from __future__ import annotations

import dataclasses
import re
import typing

import pytest
import yaml
from conftest import REPO

from swir_tracker_ros.core.filters import FILTERS, BaseFilter
from swir_tracker_ros.core.params import PIPELINES, TrackerParams
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.kalman import HUBER_K, Huber
from swir_tracker_ros.nodes.param_docs import markdown_table
from swir_tracker_ros.paramfield import flat_fields, validate_params


def _params_classes(cls: type) -> list[type]:
    """cls and every params dataclass nested in it."""
    out = [cls]
    for f in dataclasses.fields(cls):
        kind = typing.get_type_hints(cls)[f.name]
        if dataclasses.is_dataclass(kind):
            out += _params_classes(kind)
    return out


def _yaml_leaves(values: dict, prefix: str = "") -> dict:
    out: dict = {}
    for k, v in values.items():
        out.update(_yaml_leaves(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k: v})
    return out


def test_each_pipeline_has_one_class_and_one_nested_params_block() -> None:
    assert set(FILTERS) == set(PIPELINES)
    fields = dataclasses.fields(TrackerParams)
    nested = {f.name for f in fields if dataclasses.is_dataclass(f.default_factory)}
    assert set(PIPELINES) <= nested  # one nested Params per base tracker, named like the pipeline
    for name, cls in FILTERS.items():
        assert issubclass(cls, BaseFilter) and cls.name == name
        assert cls.own_params(TrackerParams()) is not None


def test_yaml_and_docs_are_generated_from_the_dataclasses() -> None:
    leaves = {name: default for name, _, default in flat_fields(TrackerParams)}
    classes = _params_classes(TrackerParams)
    assert len(classes) >= 3  # TrackerParams, KCFParams, DCFCAParams
    for cls in classes:
        for f in dataclasses.fields(cls):
            assert f.metadata.get("doc"), f"{cls.__name__}.{f.name} has no doc"
    doc = yaml.safe_load((REPO / "params" / "tracker.yaml").read_text())
    core = doc["/**"]["ros__parameters"]["tracker"]
    assert _yaml_leaves(core) == pytest.approx(leaves), "run tracker --params-yaml > params/tracker.yaml"
    docs = (REPO / "docs" / "tracker_node.md").read_text()
    assert markdown_table(TrackerParams, "tracker.") in docs, (
        "run: python -m swir_tracker_ros.param_files"
    )


def test_one_validation_names_the_nested_parameter() -> None:
    p = TrackerParams()
    validate_params(p)
    p.kcf.padding = 9.0
    with pytest.raises(ParameterError, match=r"kcf\.padding"):
        p.validate()
    p = TrackerParams()
    p.dcf_ca.lambda2 = float("inf")
    with pytest.raises(ParameterError, match=r"dcf_ca\.lambda2.*finite"):
        p.validate()
    p = TrackerParams()
    p.kcf.feature = "sift"
    with pytest.raises(ParameterError, match="feature"):
        p.validate()


def test_huber_default_is_written_once() -> None:
    assert Huber().k == HUBER_K == TrackerParams().fixed_huber_threshold
    # the 8 former copies (issue 15): Huber(1.5), k: float = 1.5 arguments, the adaptive-R field default
    pattern = re.compile(r"Huber\(1\.5|k: float = 1\.5|default=1\.5, metadata=\{\"doc\": \"Huber")
    offenders = [
        f"{path.name}: {line.strip()}"
        for path in (REPO / "swir_tracker_ros").rglob("*.py")
        for line in path.read_text().splitlines()
        if pattern.search(line)
    ]
    assert offenders == [], offenders
