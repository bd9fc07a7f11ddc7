# SPDX-License-Identifier: Apache-2.0
"""The tracker's state: `Track`, the base filter and the policies of one target, and `Frame`, what one frame's
stages decided (`Tracker._step`, docs/tracking_core.md "Per-frame loop")."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.policies.coast import CoastModel
from swir_tracker_ros.policies.lead import NetworkLead
from swir_tracker_ros.policies.lookalike import LookalikeGuard, Takeback
from swir_tracker_ros.policies.memory import AppearanceMemory
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.policies.occlusion import OcclusionVerdict
from swir_tracker_ros.policies.redetection import Redetection
from swir_tracker_ros.policies.rejected import RejectedFrames
from swir_tracker_ros.policies.scale_search import ScaleResult, ScaleSearch
from swir_tracker_ros.policies.sweep import Jump, LongLossSweep
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.policies.update_gate import UpdateGate
from swir_tracker_ros.tracker_params import TrackerParams
from swir_tracker_ros.types import Box, SearchMode


class Track:
    """The per-track state: the base filter and the policies of one target (built by `Tracker.init`); a
    policy whose Params are None is not built (`TrackerParams.check` refuses one that would do nothing)."""

    def __init__(self, p: TrackerParams, base: BaseFilter, box: Box, frame_shape: tuple[int, ...]) -> None:
        self.base = base
        self.frame_shape = frame_shape
        self.init_size = (box.w, box.h)
        self.box = box  # the current estimate, conditioned-image pixels
        self.trail = Trail(p.trail_frames)
        self.trail.remember_size(box)
        self.coast = CoastModel(p.coast)
        self.motion = MotionFilter(p.motion, base, box) if p.motion is not None else None
        self.lookalike = LookalikeGuard(p.lookalike, self.trail) if p.lookalike is not None else None
        self.lead = NetworkLead(p.lead, base.net) if p.lead is not None else None  # type: ignore[attr-defined]
        if self.lead is not None:  # the network leads: the motion policies and the network only
            return
        self.verdict = OcclusionVerdict(p.occlusion, base.failed, base.psr_reacquisition)
        self.gate = UpdateGate(p.update)
        self.scales = ScaleSearch(p.scale)
        self.redetection = Redetection(p.redetection)
        self.memory = AppearanceMemory(p.memory, base) if p.memory is not None else None
        self.sweep = LongLossSweep(p.sweep, p.redetection) if p.sweep is not None else None
        self.rejected = RejectedFrames(p.rejected) if p.rejected is not None else None

    def clamp_size(self, box: Box) -> Box:
        """Keep the size within [1/4, 4] x the initial size so one bad scale step cannot run away."""
        w0, h0 = self.init_size
        w = min(max(box.w, 0.25 * w0), 4.0 * w0)
        h = min(max(box.h, 0.25 * h0), 4.0 * h0)
        return Box.from_center(box.cx, box.cy, w, h)


@dataclass
class Frame:
    """What one frame's stages decided, in stage order (`Tracker._step`; docs/tracking_core.md)."""

    img: np.ndarray
    pred: Box  # 1. the prediction (clamped size)
    scales: ScaleResult  # 2. the scale search at the prediction
    det: Detection  # the detection: the scale search's pick, then the guard's, re-detection's or sweep's
    best: int  # its index among the scale search's detections
    window: Box  # the search window at the prediction
    shown: tuple[Box, ...]  # the windows correlated (TrackResult.search_windows)
    failed: bool = False  # 3. the base filter's failure test
    takeback: Takeback | None = None  # 4. the look-alike guard took the box back
    mode: SearchMode = SearchMode.NORMAL  # 5. re-detection (or 7. the sweep's jump): multi-window
    rejected: bool = False  # 6. not failed, but refused by the re-acquisition bars or the memory
    weak: bool = False  # 6. refused by the re-acquisition bars
    learn: bool = False  # 6. the memory learns this frame
    scale: float = 1.0  # 6. the measured size factor
    jump: Jump | None = None  # 7. the sweep found the target away from the prediction
    threshold: float | None = None  # 8. the Huber threshold of the Kalman update
    rate: float | None = None  # 9. the model's learning rate (None: no update)
