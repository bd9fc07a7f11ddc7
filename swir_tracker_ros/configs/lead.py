# SPDX-License-Identifier: Apache-2.0
"""`lead` (ours): the Siamese network leads (policies/lead.py, issue 46): NanoTrack tracks with its own
state as its authors track, a failure verdict (policies/gone.py) says when its answer is not the target,
and a re-detection search widening from the last accepted box to the whole frame finds it again. No Kalman
filter, memory or correlation filter around it: each such layer joins only with a measured paired gain
(docs/experiments.md)."""

from __future__ import annotations

from dataclasses import replace

from swir_tracker_ros.configs.bases import base_params
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.policies.coast import CoastParams
from swir_tracker_ros.policies.lead import LeadParams
from swir_tracker_ros.policies.motion import MotionParams
from swir_tracker_ros.tracker_params import TrackerParams

NETWORK = "v3"
"""The leading network: NanoTrack v3, ahead of v2 alone on the development set (+0.041 paired over 52 videos,
SE 0.024) and within TrackerNano's speed; LightTrack-M alone is +0.018 (SE 0.017) over v3 there but 3-4 x
slower per frame (docs/experiments.md, issue 46)."""


COAST_FRAMES = 25
"""Frames a hidden target's prediction keeps the trail's velocity before it holds (1 s at 25 Hz)."""


def params(base: str | None = None) -> TrackerParams:
    fp = base_params(base, default="siamese")
    if isinstance(fp, SiameseParams):
        fp = replace(fp, version=NETWORK)
    motion = MotionParams(adaptive_threshold=False, size_velocity=False)  # judges; the network sizes
    return TrackerParams(base=fp, motion=motion, memory=None, sweep=None, rejected=None,
                         lead=LeadParams(), coast=CoastParams(frames=COAST_FRAMES), presmooth=0.0)
