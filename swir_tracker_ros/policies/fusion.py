# SPDX-License-Identifier: Apache-2.0
"""`NetworkFusion`: a Siamese network tracks beside the correlation filter; per frame, one box from both.

The two families fail on different sequences (issue 38): the network follows deformation, fast motion and
rotation that the filter loses, and drifts to look-alikes and background that the filter's discriminative
model rejects. Each tracker therefore keeps its own state, so that the failure of one does not pull the
other along, and each frame's box is chosen from the two by their own verdicts (ensemble of two
independent estimators):

- the filter's frame is `tracking` and the two boxes overlap (IoU above `agree_iou`): the mean of the two
  boxes (centres averaged, sizes by their geometric mean), and the network continues from it;
- the filter's frame is `tracking` and the boxes do not overlap: the filter's box (the network has no
  failure signal: its score stays high on a look-alike);
- the filter's frame is not `tracking` (its failure test or the re-acquisition checks rejected it): the
  network's box; the state stays the filter's, so that an occlusion is still reported as one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.paramfield import nested, param
from swir_tracker_ros.types import Box, TrackResult, TrackState


@dataclass
class FusionParams:
    """(ours) A Siamese network (core/siamese/, NanoTrack) tracking beside the base filter (module docstring
    of policies/fusion.py)."""

    network: SiameseParams = nested(SiameseParams, "the Siamese network tracker (core/siamese/params.py)")
    agree_iou: float = param(
        0.3, "the two boxes agree when their intersection over union exceeds this: their mean is the box",
        0.0, 1.0)


def box_iou(a: Box, b: Box) -> float:
    """Intersection over union of two boxes (0 for disjoint or empty boxes)."""
    iw = min(a.x + a.w, b.x + b.w) - max(a.x, b.x)
    ih = min(a.y + a.h, b.y + b.h) - max(a.y, b.y)
    inter = max(iw, 0.0) * max(ih, 0.0)
    union = a.w * a.h + b.w * b.h - inter
    return inter / union if union > 0.0 else 0.0


def mean_box(a: Box, b: Box) -> Box:
    """The mean of two estimates of one box: centres averaged, width and height by their geometric mean."""
    return Box.from_center(0.5 * (a.cx + b.cx), 0.5 * (a.cy + b.cy),
                           math.sqrt(a.w * b.w), math.sqrt(a.h * b.h))


class NetworkFusion:
    """The network's own track and the per-frame choice between it and the filter (module docstring)."""

    def __init__(self, p: FusionParams) -> None:
        self.p = p
        # built with the tracker: a missing or corrupt model is a ModelError at start-up, not on a frame
        self.net = SiameseTracker(p.network)

    def start(self, frame: np.ndarray, box: Box, bit_depth: int | None) -> None:
        """The network's template and state from the start box (input pixels)."""
        self.net.init(frame, box, bit_depth)

    def fuse(self, frame: np.ndarray, bit_depth: int | None, box: Box, tracking: bool,
             ego_shift: tuple[float, float] = (0.0, 0.0)) -> tuple[Box, str]:
        """The frame's box from the filter's `box` (input pixels) and whether its frame is `tracking`, and
        which tracker gave it: "both", "filter" or "network". Advances the network's own state (moved by
        the camera's `ego_shift` first, input pixels)."""
        cx, cy = self.net.center
        self.net.center = (cx + ego_shift[0], cy + ego_shift[1])
        found = self.net.update(frame, bit_depth).box
        if not tracking:
            return found, "network"
        if box_iou(found, box) > self.p.agree_iou:
            both = mean_box(found, box)
            self.net.center, self.net.size = both.center, (both.w, both.h)
            return both, "both"
        return box, "filter"

    def result(self, frame: np.ndarray, bit_depth: int | None, res: TrackResult,
               ego_shift: tuple[float, float]) -> TrackResult:
        """The tracker's result of the frame with the fused box (a `lost` frame as it is): the last stage of
        `Tracker.update`."""
        if res.state is TrackState.LOST:
            return res
        box, _ = self.fuse(frame, bit_depth, res.box, res.state is TrackState.TRACKING, ego_shift)
        return dataclasses.replace(res, box=box)
