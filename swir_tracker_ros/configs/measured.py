# SPDX-License-Identifier: Apache-2.0
"""`measured` (ours, the default): `robust_adaptive` on KCF with FHOG + intensity, whose confident frames
report the correlation peak itself, verified by a long-term memory, with our re-detection lattice, coast
model, look-alike guard, long-loss sweep and rejected-frame policy: every `TrackerParams` default
(docs/experiments.md says what each measured). On a base filter the look-alike guard and the sweep do not
wrap (`BaseFilter.window_policies`: DCF-CA, BACF) those two are left out."""

from __future__ import annotations

from dataclasses import replace

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.core.registry import filter_class
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    fp = base_params(base)
    if filter_class(fp).window_policies:
        return TrackerParams(base=fp)
    return replace(TrackerParams(base=fp), lookalike=None, sweep=None)
