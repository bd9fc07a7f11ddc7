# SPDX-License-Identifier: Apache-2.0
"""params/acquisition.yaml lists every AcquisitionParams field and, under `mot.`, every MotParams field."""

from __future__ import annotations

from dataclasses import fields

import yaml
from conftest import REPO

from swir_tracker_ros.acquisition.mot import MotParams
from swir_tracker_ros.acquisition.params import AcquisitionParams
from swir_tracker_ros.paramfield import validate_params


def test_yaml_covers_every_field_with_its_default() -> None:
    doc = yaml.safe_load((REPO / "params" / "acquisition.yaml").read_text())
    values = doc["/**"]["ros__parameters"]
    mot = values.pop("mot")
    for cls, given in ((AcquisitionParams, values), (MotParams, mot)):
        assert set(given) == {f.name for f in fields(cls)}, cls.__name__
        params = cls(**given)
        params.validate()
        validate_params(params)
        assert params == cls()  # the file documents the defaults
