# SPDX-License-Identifier: Apache-2.0
"""The base filters a configuration is built on, by name, at their Params' defaults."""

from __future__ import annotations

from swir_tracker_ros.core.bacf import BACFParams
from swir_tracker_ros.core.dcf_ca import DCFCAParams
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.tracker_params import FilterParams

_BASES: dict[str, type] = {"kcf": KCFParams, "dcf_ca": DCFCAParams, "bacf": BACFParams, "eco": ECOParams}


def base_params(name: str | None, default: str = "kcf") -> FilterParams:
    """Default Params of the base filter `name` (None: `default`)."""
    return _BASES[name or default]()
