# SPDX-License-Identifier: Apache-2.0
"""`robust_adaptive`: paper 000's proposed tracker: the robust Kalman filter whose Huber threshold follows
the correlation peak (eq. 38; dissertation eq. 6.9 with DCF-CA)."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import papers
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return papers(base, MotionParams(peak_centre=False))
