# SPDX-License-Identifier: Apache-2.0
"""`measured` (ours, the default): `robust_adaptive` on KCF with FHOG + intensity, whose confident frames
report the correlation peak itself, verified by a long-term memory, with our re-detection lattice, coast
model, look-alike guard, long-loss sweep and rejected-frame policy: every `TrackerParams` default
(docs/experiments.md says what each measured)."""

from __future__ import annotations

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return TrackerParams(base=base_params(base))
