# SPDX-License-Identifier: Apache-2.0
"""The base filters a configuration is built on, by name, at their Params' defaults (core/registry.py)."""

from __future__ import annotations

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.registry import filter_params


def base_params(name: str | None, default: str = "kcf") -> FilterParams:
    """Default Params of the base filter `name` (None: `default`)."""
    return filter_params(name or default)
