# SPDX-License-Identifier: Apache-2.0
"""`OcclusionVerdict`: is the frame's detection the target? The base filter's failure test (paper 000 PSR,
dissertation APCE) and (ours) the re-acquisition bars a frame must pass after an occlusion."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from swir_tracker_ros.core.base import Detection
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.types import TrackState


@dataclass
class OcclusionParams:
    """Occlusion verdict (the failure test itself is the base filter's: its Params)."""

    reacquire_peak_ratio: float = param(
        0.6,
        "(ours) re-acquisition needs a peak of at least this ratio of the mean peak of the tracked frames: "
        "a weaker peak in a window away from the prediction is no measurement (the filter coasts), and a "
        "weaker first non-failed frame after an occlusion stays `occluded`; 0: off (the papers)",
        0.0,
        2.0,
    )
    reacquire_psr: float = param(
        12.0,
        "(ours) re-acquisition also needs a PSR of at least this, a hysteresis over the failure test's PSR "
        "7: a first non-failed frame after an occlusion below it stays `occluded` (a static edge of the "
        "occluder gives PSRs of 7-12 with a peak and memory score just over their bars); only on base "
        "filters whose PSRs it was measured on (`BaseFilter.psr_reacquisition`: BACF's flatter responses "
        "keep PSRs near 7 on the target); 0: off",
        0.0,
        100.0,
    )
    max_frames: int = param(250, "(ours) frames in re-detection before the state becomes lost", 1, 100000)


class OcclusionVerdict:
    """Failure and re-acquisition tests of a frame, and the frames since the target was last tracked.

    `failure` is the base filter's test (PSR < 7, paper 000 eq. 10; APCE <= 0.6 x mean, dissertation eq.
    4.96), called once per frame on the normal-mode detection (DCF-CA's keeps a running mean). The bars
    (ours) compare a peak with the mean peak of the tracked frames: an occluder's edge or background next
    to the hidden target gives peaks well below the target's (docs/experiments.md).
    """

    def __init__(self, p: OcclusionParams, failure: Callable[[Detection], bool], psr_bar: bool) -> None:
        self.p = p
        self._failure = failure
        self._psr_bar = psr_bar  # the base filter's PSRs are the ones reacquire_psr was measured on
        self.occluded = 0  # frames since the last tracked frame
        self.peak_sum, self.peak_n = 0.0, 0  # peaks of the tracked frames

    def failed(self, det: Detection) -> bool:
        """The base filter's failure (occlusion) test of `det`."""
        return self._failure(det)

    def mean_bar(self, ratio: float, default: float = 0.0) -> float:
        """ratio x the mean peak of the tracked frames (`default` before the first one)."""
        return ratio * self.peak_sum / self.peak_n if self.peak_n else default

    def weak(self, peak: float, ratio: float | None = None) -> bool:
        """Is `peak` below `ratio` (default `reacquire_peak_ratio`) x the tracked frames' mean peak? No
        before the first tracked frame, and never with a ratio of 0."""
        bar = self.p.reacquire_peak_ratio if ratio is None else ratio
        if bar <= 0.0 or not self.peak_n:
            return False
        return peak < bar * self.peak_sum / self.peak_n

    def low_psr(self, psr: float) -> bool:
        """Is `psr` below the re-acquisition bar `reacquire_psr` (base filters with that bar only)?"""
        return self._psr_bar and self.p.reacquire_psr > 0.0 and psr < self.p.reacquire_psr

    def rejects(self, det: Detection) -> bool:
        """A non-failed frame after an occlusion is not the target back when its peak is weak or its PSR
        below the re-acquisition bar."""
        return self.occluded > 0 and (self.weak(det.peak) or self.low_psr(det.psr))

    def tracked(self, peak: float) -> None:
        """A `tracking` frame with this peak."""
        self.occluded = 0
        self.peak_sum += peak
        self.peak_n += 1

    def missed(self) -> TrackState:
        """A frame that is not `tracking`: occluded, or lost after `max_frames` of them."""
        self.occluded += 1
        return TrackState.LOST if self.occluded > self.p.max_frames else TrackState.OCCLUDED
