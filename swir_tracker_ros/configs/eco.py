# SPDX-License-Identifier: Apache-2.0
"""`eco` (ours): the ECO base filter (core/eco/, ECO-HC's configuration where measured no worse) inside the
long-term layers: its PSR failure test (paper 000's 7 and a fraction of the recent mean), the papers' 3x3
re-detection grid around the robust Kalman filter's prediction, learning only on frames that pass the test.
Best on the shared sequences, not on the synthetic occlusions: not the default (docs/eco.md)."""

from __future__ import annotations

from swir_tracker_ros.configs._papers import without_our_policies
from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.policies.coast import CoastParams
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.policies.scale_search import ScaleSearchParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return without_our_policies(
        base_params(base, default="eco"),
        MotionParams(size_velocity=False),  # ECO measures the size: smoothed, not extrapolated
        ScaleSearchParams(n=1, climb=False, redetect_scales=0.0),  # ECO's own scale estimate
        CoastParams(),
    )
