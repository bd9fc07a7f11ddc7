# SPDX-License-Identifier: Apache-2.0
"""`kalman`: paper 000's pipeline with the standard Kalman filter (the comparison of its Sec. IV): 5 scales,
failure test, 3x3 re-detection grid around the prediction, confident-only update."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import papers
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return papers(base, MotionParams(robust=False, adaptive_threshold=False, peak_centre=False))
