# SPDX-License-Identifier: Apache-2.0
"""The tracker's parameter contract: named configurations, Params per layer, the YAML block and docs table."""

from __future__ import annotations

import dataclasses
import re

import pytest
import yaml
from conftest import REPO

from swir_tracker_ros.configs import BASES, CONFIGURATIONS, DEFAULT_CONFIGURATION, configuration
from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.core.dcf_ca import DCFCAParams
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.core.registry import BASE_FILTERS, make_filter
from swir_tracker_ros.errors import ModelError, ParameterError
from swir_tracker_ros.kalman import HUBER_K, Huber
from swir_tracker_ros.nodes.param_docs import markdown_table
from swir_tracker_ros.paramfield import flat_fields, validate_params
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker import TrackerParams

PAPERS = ("cf", "kalman", "robust", "robust_adaptive", "robust_adaptive_r")


def _yaml_leaves(values: dict, prefix: str = "") -> dict:
    out: dict = {}
    for k, v in values.items():
        out.update(_yaml_leaves(v, f"{prefix}{k}.") if isinstance(v, dict) else {prefix + k: v})
    return out


def _params_objects(obj: object) -> list[object]:
    """obj and every params dataclass it holds."""
    out = [obj]
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value):
            out += _params_objects(value)
    return out


def test_the_papers_pipelines_and_the_default_are_named_configurations() -> None:
    assert set(PAPERS) | {"measured", "eco", "siamese", "fused", "lead", "judged"} == set(CONFIGURATIONS)
    assert TrackerParams() == configuration("measured")  # the dataclass defaults: the CF pipeline's layers
    assert configuration("lead").lead is not None and DEFAULT_CONFIGURATION in CONFIGURATIONS
    for name in CONFIGURATIONS:
        for base in (None, *BASES):
            if name in ("lead", "judged") and base not in (None, "siamese"):  # the network leads alone
                with pytest.raises(ParameterError, match="lead"):
                    configuration(name, base)
                continue
            configuration(name, base).validate()
    assert configuration("cf").motion is None  # the bare filter
    assert configuration("kalman").motion == MotionParams(robust=False, adaptive_threshold=False,
                                                          peak_centre=False)
    assert configuration("robust_adaptive_r").motion.adaptive_r
    for name in PAPERS:  # none of our long-term policies in the papers' pipelines
        p = configuration(name)
        assert (p.memory, p.lookalike, p.sweep, p.rejected) == (None, None, None, None)
        assert p.redetection.lattice_step == 0.0 and p.presmooth == 0.0
        assert p.base.feature == "hog_soft" and p.base.update_gate == "peak"
        assert (p.occlusion.reacquire_peak_ratio, p.occlusion.reacquire_psr) == (0.0, 0.0)
        assert (p.scale.penalty, p.scale.climb, p.scale.redetect_scales) == (1.0, False, 0.0)
        assert (p.coast.trail_velocity, p.coast.size_hold_peak_ratio, p.update.unconfident_rate) == (
            False, 0.0, 0.0)
    assert isinstance(configuration("robust_adaptive_r", "dcf_ca").base, DCFCAParams)


def test_an_unknown_configuration_or_base_names_the_known_ones() -> None:
    with pytest.raises(ParameterError, match=r"unknown tracker configuration 'measure'.*robust_adaptive"):
        configuration("measure")
    with pytest.raises(ParameterError, match=r"unknown base filter 'eco2'; known: kcf, dcf_ca, bacf"):
        configuration("measured", "eco2")


def test_the_base_filter_is_chosen_by_the_type_of_its_params() -> None:
    for name, filter_cls in BASE_FILTERS.items():
        assert issubclass(filter_cls, BaseFilter) and filter_cls.name == name  # the one interface
        try:
            filter_cls.check_resources(filter_cls.Params())
        except ModelError:  # a network without its weights (SWIR_TRACKER_MODELS empty): not built here
            continue
        assert isinstance(make_filter(filter_cls.Params(), 40.0, 100.0), filter_cls)
    with pytest.raises(ParameterError, match="no base filter takes MotionParams"):
        make_filter(MotionParams(), 40.0, 100.0)


def test_only_the_configuration_files_compare_configuration_or_base_names() -> None:
    """No code outside swir_tracker_ros/configs/ tests a configuration or base-filter name (issue 30)."""
    names = "|".join(re.escape(n) for n in (*CONFIGURATIONS, *BASES))
    pattern = re.compile(rf"""(==|!=|\bin)\s*\(?\s*["']({names})["']|["']({names})["']\s*(==|!=)""")
    offenders = [
        f"{path.relative_to(REPO)}: {line.strip()}"
        for path in (REPO / "swir_tracker_ros").rglob("*.py")
        if "configs" not in path.parts
        for line in path.read_text().splitlines()
        if pattern.search(line)
    ]
    assert offenders == [], offenders


def test_yaml_and_docs_are_generated_from_the_dataclasses() -> None:
    leaves = {name: value for name, _, value in flat_fields(configuration(DEFAULT_CONFIGURATION))}
    for obj in _params_objects(TrackerParams()):
        for f in dataclasses.fields(obj):
            assert f.metadata.get("doc"), f"{type(obj).__name__}.{f.name} has no doc"
    doc = yaml.safe_load((REPO / "params" / "tracker.yaml").read_text())
    core = _yaml_leaves(doc["/**"]["ros__parameters"]["tracker"])
    assert core.pop("configuration") == DEFAULT_CONFIGURATION and core.pop("base_filter") == ""
    assert core == pytest.approx(leaves), "run: python -m swir_tracker_ros.param_files"
    docs = (REPO / "docs" / "tracker_node.md").read_text()
    assert markdown_table(TrackerParams, "tracker.") in docs, "run: python -m swir_tracker_ros.param_files"


def test_one_validation_names_the_nested_parameter() -> None:
    p = TrackerParams()
    validate_params(p)
    p.base.padding = 9.0
    with pytest.raises(ParameterError, match=r"base\.padding"):
        p.validate()
    p = configuration("robust_adaptive", "dcf_ca")
    p.base.lambda2 = float("inf")
    with pytest.raises(ParameterError, match=r"base\.lambda2.*finite"):
        p.validate()
    p = TrackerParams()
    p.base.feature = "sift"
    with pytest.raises(ParameterError, match="feature"):
        p.validate()
    p = TrackerParams()
    p.memory.ratio = -1.0
    with pytest.raises(ParameterError, match=r"memory\.ratio"):
        p.validate()
    with pytest.raises(ParameterError, match=r"parameter scale must be a ScaleSearchParams"):
        TrackerParams(scale=None).validate()  # a policy every tracker has cannot be left out
    with pytest.raises(ParameterError, match=r"parameter base must be a FilterParams"):
        TrackerParams(base=MotionParams()).validate()
    assert isinstance(TrackerParams().base, KCFParams)


def test_huber_default_is_written_once() -> None:
    assert Huber().k == HUBER_K == MotionParams().fixed_threshold
    # the 8 former copies (issue 15): Huber(1.5), k: float = 1.5 arguments, the adaptive-R field default
    pattern = re.compile(r"Huber\(1\.5|k: float = 1\.5|default=1\.5, metadata=\{\"doc\": \"Huber")
    offenders = [
        f"{path.name}: {line.strip()}"
        for path in (REPO / "swir_tracker_ros").rglob("*.py")
        for line in path.read_text().splitlines()
        if pattern.search(line)
    ]
    assert offenders == [], offenders
