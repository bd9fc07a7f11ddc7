# SPDX-License-Identifier: Apache-2.0
"""`CoastModel`: how the Kalman state moves while the target is not measured (re-detection, weak frames)."""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.policies.trail import Trail


@dataclass
class CoastParams:
    """The motion the prediction keeps while the target is hidden."""

    trail_velocity: bool = param(
        True,
        "(ours) when tracking turns to re-detection, the centre velocity becomes the mean velocity of the "
        "tracked centre over the trail (trail_frames, ego shifts removed) instead of the Kalman's: a target "
        "that walks on keeps its pace, one that turned on the spot or jittered is not carried away; false: "
        "the Kalman velocity (the papers)",
    )
    velocity_decay: float = param(
        1.0,
        "(ours) per-frame factor on the centre velocity while re-detecting: 1 holds the pre-occlusion "
        "motion (the papers' premise); below 1 the prediction slows down and stays near where the target "
        "was last seen while the lattice widens around it",
        0.0,
        1.0,
    )
    frames: int = param(
        0,
        "(ours) frames of re-detection after which the centre velocity is set to zero: the pre-occlusion "
        "motion carries the prediction through a short occlusion, a longer one is searched around where "
        "the prediction stands; 0: never",
        0,
        100000,
    )
    size_hold_peak_ratio: float = param(
        0.6,
        "(ours) a tracked frame whose peak is below this ratio of the tracked peaks' mean zeroes the size "
        "velocity before its Kalman update: the sizes of weak, changing responses (a target that turns) "
        "are measured but not extrapolated, so the box does not shrink away frame after frame; 0: off (the "
        "papers)",
        0.0,
        2.0,
    )


class CoastModel:
    """The state edits of frames without a trusted measurement.

    Re-detection measures no size (it is taken from the prediction), so nothing could correct a size
    velocity: the size is held instead of extrapolated through the whole occlusion (every
    configuration). The centre keeps the pre-occlusion motion (paper 000's premise), optionally the
    trail's mean velocity, decayed and stopped after `frames` (ours).
    """

    def __init__(self, p: CoastParams) -> None:
        self.p = p

    def redetecting(self, motion: MotionFilter, occluded: int) -> None:
        """A failed frame (`occluded` frames since the last tracked one): hold the size, decay the motion."""
        motion.hold_size()
        motion.scale_velocity(self.p.velocity_decay)
        if 0 < self.p.frames <= occluded:
            motion.stop()

    def start(self, motion: MotionFilter, trail: Trail) -> None:
        """The first frame that is not tracked: the centre velocity from the trail (`trail_velocity`).

        Over the whole trail window: a trail shorter than the window (a track just started) counts the
        rest as standing still, so a few frames' motion does not carry the prediction through an
        occlusion.
        """
        centres = trail.centres
        if not self.p.trail_velocity or len(centres) < 2:
            return
        (t0, x0, y0), (t1, x1, y1) = centres[0], centres[-1]
        span = max(t1 - t0, float(trail.window))
        motion.set_velocity((x1 - x0) / span, (y1 - y0) / span)
