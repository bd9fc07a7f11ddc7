# SPDX-License-Identifier: Apache-2.0
"""params/positioner.yaml lists every PositionerParams field with a valid value."""

from __future__ import annotations

from dataclasses import fields

import yaml
from conftest import REPO

from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.pelco.params import PositionerParams


def test_yaml_covers_every_field_and_validates() -> None:
    doc = yaml.safe_load((REPO / "params" / "positioner.yaml").read_text())
    values = doc["/**"]["ros__parameters"]
    assert set(values) == {f.name for f in fields(PositionerParams)}
    params = PositionerParams(**values).validate()
    validate_params(params)
    assert params == PositionerParams()  # the file documents the defaults


def test_every_field_is_documented_in_the_readme() -> None:
    text = (REPO / "docs" / "positioner.md").read_text()
    missing = [f.name for f in fields(PositionerParams) if f"`{f.name}`" not in text]
    assert not missing, f"docs/positioner.md does not document {missing}"
