# SPDX-License-Identifier: Apache-2.0
"""`robust`: paper 000's pipeline with the M-robust (Huber) Kalman filter at the fixed threshold k = 1.5
(paper 001)."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import papers
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return papers(base, MotionParams(adaptive_threshold=False, peak_centre=False))
