# SPDX-License-Identifier: Apache-2.0
"""`TrackerParams`: the tracker's parameters, one Params dataclass per layer and policy it composes.

The defaults are our correlation-filter configuration (`measured`, swir_tracker_ros/configs/measured.py);
the papers' configurations and the network-led one (`lead`, configs/lead.py) build theirs in plain code
from these, leaving policies out (None) or setting their own values. ROS names: `tracker.<field>.<subfield>`
(`tracker.base.padding`, `tracker.memory.ratio`).
"""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.core.base import FilterParams
from swir_tracker_ros.core.conditioning import ConditioningConfig
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.core.registry import filter_class
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import nested, param, validate_params
from swir_tracker_ros.policies.coast import CoastParams
from swir_tracker_ros.policies.fusion import FusionParams
from swir_tracker_ros.policies.lead import LeadParams
from swir_tracker_ros.policies.lookalike import LookalikeParams
from swir_tracker_ros.policies.memory import MemoryParams
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.policies.occlusion import OcclusionParams
from swir_tracker_ros.policies.redetection import RedetectionParams
from swir_tracker_ros.policies.rejected import RejectedParams
from swir_tracker_ros.policies.scale_search import ScaleSearchParams
from swir_tracker_ros.policies.sweep import SweepParams
from swir_tracker_ros.policies.update_gate import UpdateGateParams


@dataclass
class TrackerParams:
    """Every knob of `Tracker`, grouped by the layer or policy that reads it. A policy set to None is not
    part of the tracker (the papers' configurations)."""

    base: FilterParams = nested(
        KCFParams, "the base correlation filter: core/kcf.py KCFParams (paper 000 KCF), core/dcf_ca.py "
        "(the dissertation's DCF-CA), core/bacf.py (BACF), core/eco/params.py (ECO)")
    scale: ScaleSearchParams = nested(
        ScaleSearchParams, "size search at the prediction (policies/scale_search.py)")
    motion: MotionParams | None = nested(
        MotionParams, "the box's Kalman filter (policies/motion.py); none: the bare correlation filter")
    occlusion: OcclusionParams = nested(
        OcclusionParams, "occlusion verdict and re-acquisition bars (policies/occlusion.py)")
    redetection: RedetectionParams = nested(
        RedetectionParams, "re-detection search around the prediction (policies/redetection.py)")
    memory: MemoryParams | None = nested(
        MemoryParams, "long-term appearance memory verifying the tracked frames (policies/memory.py)")
    lookalike: LookalikeParams | None = nested(
        LookalikeParams, "look-alike guard of the tracked frames (policies/lookalike.py)")
    sweep: SweepParams | None = nested(
        SweepParams, "long-loss sweep over the whole image (policies/sweep.py)")
    coast: CoastParams = nested(
        CoastParams, "motion of the prediction while not measured (policies/coast.py)")
    rejected: RejectedParams | None = nested(
        RejectedParams, "update and size of a rejected frame (policies/rejected.py)")
    update: UpdateGateParams = nested(UpdateGateParams, "model update gate (policies/update_gate.py)")
    fusion: FusionParams | None = nested(
        lambda: None, "a Siamese network tracking beside the base filter, one box from both "
        "(policies/fusion.py); none: the base filter alone")
    lead: LeadParams | None = nested(
        lambda: None, "(ours) the Siamese network base filter leads with its own state, judged by its "
        "appearance and by the motion filter's prediction, with a re-detection around the prediction "
        "(policies/lead.py); none: the base filter inside the Kalman layers")
    conditioning: ConditioningConfig = nested(
        ConditioningConfig, "frame conditioning before any window is sampled (core/conditioning.py)")
    trail_frames: int = param(
        50,
        "(ours) frames of tracked history (centres with ego shifts removed, sizes) kept for the coast "
        "model's mean velocity, the look-alike guard's motion reference and a rejected frame's size",
        0,
        100000,
    )
    presmooth: float = param(
        0.02,
        "(ours) Gaussian blur of the conditioned frame before any window is sampled, sigma = this x "
        "sqrt(w h) of the start box (0.02: 0.8-1.3 px for 25x72-40x100 px targets): windows sampled at "
        "sub-pixel positions are smoothed unequally by the bilinear interpolation, so two start boxes a "
        "pixel apart learn differently smoothed templates; 0: off (the papers)",
        0.0,
        0.2,
    )

    def validate(self) -> None:
        """Raise ParameterError naming the first parameter of the wrong type or out of range, or a
        combination of policies in which one would do nothing (`check`)."""
        validate_params(self)

    def check(self) -> None:
        """A policy is in the tracker (its Params) or out (None), never in and idle: refuse a combination
        in which one would do nothing (run by `validate_params` after the fields)."""
        if self.motion is None:  # the bare correlation filter: one window, no long-term policy
            idle = [n for n in ("memory", "lookalike", "sweep", "rejected") if getattr(self, n) is not None]
            if idle:
                raise ParameterError(f"parameters {', '.join(idle)}: the bare correlation filter (motion: "
                                     "None) runs none of them; set them to None")
        base = filter_class(self.base)
        if not base.window_policies and self.lead is None:  # what the guard and the sweep may wrap
            idle = [n for n in ("lookalike", "sweep") if getattr(self, n) is not None]
            if idle:
                raise ParameterError(f"parameters {', '.join(idle)}: the look-alike guard and the long-loss "
                                     f"sweep do not wrap base filter {base.name} (window_policies); set "
                                     "them to None")
        if self.lead is not None:
            if not base.can_lead or self.motion is None or self.fusion is not None:
                raise ParameterError(f"parameter lead: base filter {base.name} cannot lead (only the Siamese "
                                     "network can), nor a track without the motion filter (its prediction "
                                     "judges the network) or with the fusion (set it to None)")
            idle = [n for n in ("memory", "sweep", "rejected") if getattr(self, n) is not None]
            if idle:
                raise ParameterError(f"parameters {', '.join(idle)}: a network-led track runs none of them "
                                     "(policies/lead.py); set them to None")
            if self.conditioning.downscale != 1.0:
                raise ParameterError("parameter lead: the network takes the input frame (conditioning."
                                     "downscale must be 1)")
        if self.sweep is not None and self.redetection.lattice_step <= 0.0:
            raise ParameterError("parameter sweep: the long-loss sweep searches the re-detection lattice, "
                                 "off with redetection.lattice_step 0; set sweep to None")
