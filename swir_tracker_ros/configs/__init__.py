# SPDX-License-Identifier: Apache-2.0
"""Named tracker configurations, one per file (pytracking's parameter files): `configuration(name)`.

The papers' pipelines as the papers describe them (`cf`, `kalman`, `robust`, `robust_adaptive`,
`robust_adaptive_r`: paper 000 and the dissertation), our correlation-filter pipeline (`measured`, the
`TrackerParams` defaults, the default) and `lead` (the Siamese network leads, judged by its motion). Each
file builds one `TrackerParams` in plain code; choosing one is a name, and only this package compares names.
The base filter is part of a configuration (paper 000: KCF); `base` swaps it for another one (`dcf_ca`: the
dissertation's DCF-CA, `bacf`) with the configuration's own adjustments for it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType

from swir_tracker_ros.configs import (
    cf,
    eco,
    fused,
    judged,
    kalman,
    lead,
    measured,
    robust,
    robust_adaptive,
    robust_adaptive_r,
    siamese,
)
from swir_tracker_ros.core.registry import BASE_FILTERS
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.tracker_params import TrackerParams

_MODULES: tuple[ModuleType, ...] = (cf, kalman, robust, robust_adaptive, robust_adaptive_r, measured, eco,
                                  siamese, fused, lead, judged)
CONFIGURATIONS: dict[str, Callable[[str | None], TrackerParams]] = {
    m.__name__.rsplit(".", 1)[-1]: m.params for m in _MODULES
}
"""Every named configuration: name -> builder(base name or None)."""
DEFAULT_CONFIGURATION = "measured"
"""The default: our correlation-filter pipeline, which needs no model files. `lead` (the Siamese network
leads, judged by its appearance and its motion, configs/lead.py) tracks better on real video but still loses
the synthetic occlusions' overlap and the closed-loop demo (docs/experiments.md, issue 52)."""
BASES = tuple(BASE_FILTERS)
"""The base filters a configuration can be built on (core/registry.py)."""


def configuration(name: str, base: str | None = None) -> TrackerParams:
    """The `TrackerParams` of the configuration `name` (on the base filter `base`, None: its own);
    ParameterError naming the known ones when either name is unknown."""
    try:
        build = CONFIGURATIONS[name]
    except KeyError:
        raise ParameterError(
            f"unknown tracker configuration {name!r}; known: {', '.join(CONFIGURATIONS)}") from None
    if base is not None and base not in BASES:
        raise ParameterError(f"unknown base filter {base!r}; known: {', '.join(BASES)}")
    params = build(base)
    params.validate()
    return params


@dataclass
class ConfigurationChoice:
    """Which configuration the tracker node builds (ROS: `tracker.configuration`, `tracker.base_filter`),
    read at start-up; the configuration's own parameters are declared with its values as defaults."""

    configuration: str = param(
        DEFAULT_CONFIGURATION,
        "named tracker configuration (swir_tracker_ros/configs/): measured (the default: our correlation-"
        "filter pipeline, no model files), lead (the Siamese network leads, judged by its motion; needs the "
        "model files of `make models`), judged (lead with a second network's opinion and a judge), the "
        "papers' pipelines",
        choices=tuple(CONFIGURATIONS),
        read_only=True,
    )
    base_filter: str = param(
        "",
        "base correlation filter of the configuration; '' = the configuration's own (kcf)",
        choices=("", *BASES),
        read_only=True,
    )

    def build(self) -> TrackerParams:
        """The chosen configuration's TrackerParams."""
        return configuration(self.configuration, self.base_filter or None)
