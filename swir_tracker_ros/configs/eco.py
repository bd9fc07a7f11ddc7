# SPDX-License-Identifier: Apache-2.0
"""`eco` (ours): the ECO base filter (core/eco/, ECO-HC's configuration where measured no worse) inside the
long-term layers: its PSR failure test (paper 000's 7 and a fraction of the recent mean), the papers' 3x3
re-detection grid around the robust Kalman filter's prediction, learning only on frames that pass the test.
Best on the shared sequences, not on the synthetic occlusions: not the default (docs/eco.md)."""

from __future__ import annotations

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.policies.occlusion import OcclusionParams
from swir_tracker_ros.policies.redetection import RedetectionParams
from swir_tracker_ros.policies.scale_search import ScaleSearchParams
from swir_tracker_ros.policies.update_gate import UpdateGateParams
from swir_tracker_ros.tracker_params import TrackerParams


def params(base: str | None = None) -> TrackerParams:
    return TrackerParams(
        base=base_params(base, default="eco"),
        scale=ScaleSearchParams(n=1, climb=False, redetect_scales=0.0),  # ECO's own scale estimate
        motion=MotionParams(size_velocity=False),  # ECO measures the size: smoothed, not extrapolated
        occlusion=OcclusionParams(reacquire_peak_ratio=0.0, reacquire_psr=0.0),
        redetection=RedetectionParams(lattice_step=0.0, prior=0.0),
        memory=None,
        lookalike=None,
        sweep=None,
        rejected=None,
        update=UpdateGateParams(unconfident_rate=0.0),
        presmooth=0.0,
    )
