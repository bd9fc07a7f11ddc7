# SPDX-License-Identifier: Apache-2.0
"""`robust_adaptive_r`: `robust_adaptive` plus the dissertation's adaptive measurement noise R (eq. 5.95)."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import papers
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return papers(base, MotionParams(peak_centre=False, adaptive_r=True))
