# SPDX-License-Identifier: Apache-2.0
"""`AppearanceMemory`: the long-term memory that verifies every `tracking` frame (LCT style, ours here)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.types import Box


@dataclass
class MemoryParams:
    """The memory filter: a copy of the first-frame filter, learnt conservatively (Ma et al., "Long-term
    correlation tracking", CVPR 2015, Sec. 3.2-3.3)."""

    ratio: float = param(
        0.5,
        "(ours) a frame is `tracking` only when the memory filter's peak on the box reaches this ratio of "
        "its mean over the verified frames; a rejected frame is `occluded` and teaches neither filter",
        0.0,
        2.0,
    )
    rate: float = param(
        0.01, "(ours) learning rate of the memory on frames whose memory peak is above its mean", 0.0, 1.0
    )

    def check(self) -> None:
        """A memory that rejects no frame is no policy: it is switched off by leaving it out (None)."""
        if self.ratio <= 0.0:
            raise ParameterError(f"parameter ratio = {self.ratio} rejects no frame; leave the memory out "
                                 "(memory: None) to switch it off")


class AppearanceMemory:
    """Verdict of the long-term memory on a frame's winning window.

    The memory (first-frame model, then learnt at `rate` only from frames it scores above its own mean)
    must find the target in the winning window with a peak of at least `ratio` x its mean over the
    verified frames; otherwise the box is on something the memory does not know (background, a
    distractor) and the frame is `occluded`, not `tracking`. The filter object lives in the base filter
    (`BaseFilter.start_memory`), which scores the windows of its last detection.
    """

    def __init__(self, p: MemoryParams, base: BaseFilter) -> None:
        self.p = p
        self.base = base
        base.start_memory()
        self.peak_sum, self.peak_n = 0.0, 0  # memory peaks of the verified frames

    def mean_bar(self, ratio: float) -> float:
        """ratio x the memory's mean peak over the verified frames (callers check `peak_n` first)."""
        return ratio * self.peak_sum / self.peak_n

    def knows(self, index: int) -> bool:
        """Does the memory find the target in window `index` of the last detection (peak >= ratio x its
        mean)? No side effects; before the first verified frame, yes."""
        if not self.peak_n:
            return True
        return self.base.memory_score(index) >= self.mean_bar(self.p.ratio)

    def verdict(self, index: int) -> tuple[bool, bool]:
        """(rejected, learn) for a non-failed frame won by window `index`; `learn`: the caller trains the
        memory on the frame's posterior box (`learn`)."""
        m = self.base.memory_score(index)
        mean = self.peak_sum / self.peak_n if self.peak_n else m
        if m < self.p.ratio * mean:
            return True, False
        self.peak_sum += m
        self.peak_n += 1
        return False, m >= mean and self.p.rate > 0.0

    def learn(self, img: np.ndarray, box: Box) -> None:
        """Blend the memory with the window around `box` at `rate`."""
        self.base.train_memory(img, box, self.p.rate)
