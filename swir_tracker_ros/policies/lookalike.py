# SPDX-License-Identifier: Apache-2.0
"""`LookalikeGuard`: a same-looking object passing in front must not take the box along (ours)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.core.windows import scale_windows
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.occlusion import OcclusionVerdict
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.types import Box

CHECKS = 2  # frames of a departure from the motion reference on which the guard looks
GAP = 3.0  # frames: a longer break in the trail ends the motion reference


@dataclass
class LookalikeParams:
    """Look-alike guard of the tracked frames (demo_crossing; docs/experiments.md, tenth pass)."""

    frames: int = param(
        12,
        "(ours) a tracked peak further than `distance` from where the trail's motion before its last this "
        "many frames puts the target (ego shifts removed) also has a window correlated there; a peak in "
        "that window, near that reference and apart from the first, of at least `ratio` x the first peak "
        "is the target, and the frames since the reference are dropped from the trail",
        1,
        1000,
    )
    distance: float = param(
        0.5,
        "(ours) the distance from the motion reference, in box widths and heights (the larger), beyond "
        "which a tracked peak is checked; the second peak must lie within half of it from the reference "
        "and at least half of it from the first peak",
        0.05,
        5.0,
    )
    ratio: float = param(
        0.8,
        "(ours) the peak at the motion reference wins at this ratio of the peak that left it (the motion "
        "is the tie-break between two targets that look alike)",
        0.1,
        2.0,
    )


@dataclass(frozen=True)
class Takeback:
    """The guard's decision to take the box back: the detections (the scale search's windows plus the one
    at the reference), the winner's index (that window), the window and the reference's velocity."""

    dets: list[Detection]
    best: int
    window: Box
    velocity: tuple[float, float]


class LookalikeGuard:
    """Look-alike guard of a tracked frame.

    A same-looking object that passes in front of the target covers it and takes the correlation peak
    along; every frame's step is small and confident, so neither the failure test, the Kalman gate nor
    the memory notices. The motion does: the peak leaves where the trail's earlier motion puts the target
    (`reference`). When it is further than `distance` from there, one more window is correlated at the
    reference; its peak wins when it lies near the reference and apart from the first, at `ratio` of its
    height or more, and passes the re-acquisition bars: a distractor-aware choice by motion, as
    multi-target trackers gate by a motion model, the motion being the one from before the mix-up. A fast
    skater whose turn the reference cannot know leaves background there, with PSRs of 5-10 (OTB skating1).
    Only the first CHECKS frames of a departure are checked: when a look-alike takes the box away, the
    target is at the reference the moment the box leaves it; when nothing is there then, the target moved
    off the reference itself, and the reference, extrapolated on, would only pass over background (a
    stage light took a skater's box 10 frames into her start: OTB skating1 from the 0.8 start, measured).
    Base filters with a stateless failure test only (`window_policies`: KCF, ECO): DCF-CA's keeps a running
    APCE mean that a second call would move. The extra detection (the windows the scale search correlated,
    again, so that the winner's index still names its features) costs one more frame's search on at most
    CHECKS frames per departure.
    """

    def __init__(self, p: LookalikeParams, trail: Trail) -> None:
        self.p = p
        self.trail = trail
        self.departed = 0  # tracked frames since the box left the motion reference

    def reference(self) -> tuple[float, float, float, float] | None:
        """Centre and velocity (image pixels, per frame) that the trail's motion before its last `frames`
        frames gives for now: None without that much unbroken history (a gap of more than GAP frames: an
        occlusion, whose motion before it is stale)."""
        m, clock = self.p.frames, self.trail.clock
        trail = list(self.trail.centres)
        if not trail or clock - trail[-1][0] > GAP:
            return None
        start = next((i for i in range(len(trail) - 1, 0, -1) if trail[i][0] - trail[i - 1][0] > GAP), 0)
        old = [e for e in trail[start:] if e[0] <= clock - m]
        if len(old) < 2 or old[-1][0] - old[0][0] < m:
            return None
        (t0, x0, y0), (t1, x1, y1) = old[0], old[-1]
        vx, vy = (x1 - x0) / (t1 - t0), (y1 - y0) / (t1 - t0)
        dt = clock - t1
        ex, ey = self.trail.ego
        return x1 + vx * dt + ex, y1 + vy * dt + ey, vx, vy

    def departure(self, cx: float, cy: float, w: float, h: float) -> tuple[float, float, float, float] | None:
        """The motion reference (`reference`) when a tracked centre (cx, cy) of a w x h box lies further than
        `distance` from it on one of the first CHECKS frames of a departure (counted here), else None."""
        ref = self.reference()
        if ref is None or self.apart(cx, cy, ref[0], ref[1], w, h) <= self.p.distance:
            self.departed = 0
            return None
        self.departed += 1
        return ref if self.departed <= CHECKS else None  # else the target moved off the reference itself

    def takes_back(self, alt: tuple[float, float], first: tuple[float, float], ref: tuple[float, ...],
                   w: float, h: float) -> bool:
        """Where the window at the reference found a peak that may take the box back: near the reference and
        apart from the first peak (the peaks' own bars are the caller's)."""
        d = self.p.distance
        return (self.apart(*alt, ref[0], ref[1], w, h) <= d / 2
                and self.apart(*alt, *first, w, h) >= d / 2)

    @staticmethod
    def apart(ax: float, ay: float, bx: float, by: float, w: float, h: float) -> float:
        """The distance of two centres in box widths and heights (the larger)."""
        return max(abs(ax - bx) / w, abs(ay - by) / h)

    def check(self, base: BaseFilter, img: np.ndarray, det: Detection, pred: Box, wins: list[Box],
              factors: tuple[float, ...], verdict: OcclusionVerdict) -> Takeback | None:
        """The take-back of a tracked frame won by `det` (windows `wins` of sizes `factors` around the
        prediction `pred`), or None when the first peak stays."""
        w, h = pred.w * det.scale, pred.h * det.scale
        ref = self.departure(det.cx, det.cy, w, h)
        if ref is None:
            return None
        rx, ry, vx, vy = ref
        extra = scale_windows(rx, ry, pred.w, pred.h, base.padding, (1.0,))[0]
        dets = base.detect(img, [*wins, extra], [*factors, 1.0])
        alt = dets[-1]
        # taking the box back is a re-acquisition: the peak there also passes its bars (peak, PSR)
        if (self.takes_back((alt.cx, alt.cy), (det.cx, det.cy), ref, w, h)
                and alt.peak >= self.p.ratio * det.peak and not verdict.failed(alt)
                and not verdict.weak(alt.peak) and not verdict.low_psr(alt.psr)):
            return Takeback(dets, len(dets) - 1, extra, (vx, vy))
        return None

    def taken_back(self) -> None:
        """After the box was moved back: the trail forgets the frames that followed the look-alike (the
        caller sets the centre velocity to the reference's)."""
        self.departed = 0
        self.trail.forget_after(self.trail.clock - self.p.frames)
