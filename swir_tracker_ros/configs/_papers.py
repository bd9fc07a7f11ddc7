# SPDX-License-Identifier: Apache-2.0
"""What the papers' configurations share: the pipeline of paper 000 (KCF, PSR failure test, peak-gated update,
3x3 re-detection grid around the Kalman prediction) without any of our long-term policies."""

from __future__ import annotations

from dataclasses import replace

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.policies.coast import CoastParams
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.policies.occlusion import OcclusionParams
from swir_tracker_ros.policies.redetection import RedetectionParams
from swir_tracker_ros.policies.scale_search import ScaleSearchParams
from swir_tracker_ros.policies.update_gate import UpdateGateParams
from swir_tracker_ros.tracker_params import TrackerParams


def papers(base: str | None, motion: MotionParams | None) -> TrackerParams:
    """A papers' configuration on `base` (None: paper 000's KCF) with the Kalman filter `motion` (None:
    the bare correlation filter).

    - base filter: soft FHOG (paper 000: Piotr's fhog) and the update gate peak > 0.5 (paper 000) for the
      KCF-family filters; DCF-CA keeps the dissertation's APCE tests (its Params);
    - 5 scales 5 % apart, the largest peak wins (no penalty, every scale correlated);
    - the motion kept through an occlusion as the Kalman filter has it, the size held;
    - `without_our_policies`.
    """
    fp = base_params(base)
    if isinstance(fp, KCFParams):  # KCF and BACF (a KCFParams): paper 000's gate; BACF's own features
        fp = replace(fp, update_gate="peak", feature="hog_soft")
    return without_our_policies(fp, motion, ScaleSearchParams(penalty=1.0, climb=False, redetect_scales=0.0),
                                CoastParams(trail_velocity=False, size_hold_peak_ratio=0.0))


def without_our_policies(fp: FilterParams, motion: MotionParams | None, scale: ScaleSearchParams,
                         coast: CoastParams) -> TrackerParams:
    """Paper 000's long-term layers around the base filter `fp`: the failure test, the 3x3 re-detection
    grid of windows overlapping by a third (paper 000 Sec. III-B.4), the confident-frame update gate; no
    re-acquisition bars, memory, look-alike guard, sweep, rejected-frame policy, pre-smoothing."""
    return TrackerParams(
        base=fp,
        scale=scale,
        motion=motion,
        occlusion=OcclusionParams(reacquire_peak_ratio=0.0, reacquire_psr=0.0),
        redetection=RedetectionParams(lattice_step=0.0, prior=0.0),
        memory=None,
        lookalike=None,
        sweep=None,
        coast=coast,
        rejected=None,
        update=UpdateGateParams(unconfident_rate=0.0),
        presmooth=0.0,
    )
