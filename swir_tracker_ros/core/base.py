# SPDX-License-Identifier: Apache-2.0
"""`BaseFilter`: the one interface of a base filter, the short-term tracker inside the long-term policies.

OpenCV's `cv::Tracker` (`init`, `update`) and pytracking's `BaseTracker` (`initialize`, `track`) are the
models; ours has more verbs because the policies, not the filter, decide where to look and when to learn:

- `initialise(img, box)`: first-frame training;
- `detect_scales(...)`: the scale search at the prediction; `detect(img, windows)`: translation in given
  windows; `detect_grid` / `detect_lattice`: the re-detection windows around a prediction (defaults here,
  from `detect`);
- `failed(det)`: its failure (occlusion) test, `confident(det)`: its update gate;
- `train(img, box, rate)`: learn from the posterior box;
- `box_model(w, h)`, `threshold_map`, `robust_method`: the Kalman filter of its pipeline;
- `start_memory`, `memory_score`, `train_memory`, `memory_as_filter`: the long-term memory (LCT style).

Every base filter derives from it (core/template.py `TemplateFilter` for the correlation filters on a
resampled template, core/eco/base.py `ECOBase`) and is registered once in core/registry.py; the policies
are typed against it. docs/tracking_core.md "Add a base filter" is the how-to.
"""

from __future__ import annotations

import contextlib
from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.windows import grid_windows
from swir_tracker_ros.kalman import BoxModel, ThresholdMap
from swir_tracker_ros.types import Box

__all__ = ["BaseFilter", "Detection", "FilterParams"]


@dataclass
class FilterParams:
    """The Params of a base filter (`TrackerParams.base`): each filter's own dataclass derives from this
    one, and its type selects the filter (core/registry.py `make_filter`)."""


class BaseFilter(ABC):
    """A base filter: detection in the windows the policies hand in, its failure test and update gate,
    training, its Kalman box model and a long-term memory (module docstring).

    Built as `cls(fp, w, h)` from its Params `fp` (of type `Params`) and the first box's size.
    Detections are in image pixels; a window is (1 + `padding`) x the target it looks for.
    """

    name: ClassVar[str]  # the name configurations and the node use (`tracker.base_filter`)
    Params: ClassVar[type[FilterParams]]  # its Params dataclass
    robust_method: ClassVar[str]  # statistical linearisation of the robust Kalman update (kalman/statlin.py)
    threshold_map: ClassVar[ThresholdMap]  # peak -> Huber threshold (paper 000 eq. 38 / dissertation eq. 6.9)
    # (ours) re-acquisition also needs PSR >= `occlusion.reacquire_psr`: only filters whose PSRs it was
    # measured on
    psr_reacquisition: ClassVar[bool] = False
    # may the look-alike guard and the long-loss sweep wrap this filter? They test windows other than the
    # frame's own with `failed`, so its test must have no state (a second call changes nothing), and they
    # take only filters they were measured with
    window_policies: ClassVar[bool] = False
    # (ours) can it lead a track with its own state (`TrackerParams.lead`, policies/lead.py)? A Siamese
    # network: it searches from its own state and keeps its own template (`net`, a SiameseTracker)
    can_lead: ClassVar[bool] = False

    padding: float  # a window is (1 + padding) x the target
    learning_rate: float  # the rate of a confident frame's `train`
    own_scale: bool = False  # does it estimate the size itself instead of by windows of several sizes?

    @abstractmethod
    def __init__(self, fp: FilterParams, w: float, h: float) -> None:
        """The filter for Params `fp` and a first box of size w x h."""

    @classmethod
    def check_resources(cls, fp: FilterParams) -> None:
        """Raise ModelError now if the filter for `fp` needs files that are not installed (a network's
        weights), so that a configuration on it refuses to start rather than fail on the first target;
        called when the tracker is built. A correlation filter needs none."""
        return None

    # ------------------------------------------------------------------ model
    @abstractmethod
    def initialise(self, img: np.ndarray, box: Box) -> None:
        """First-frame training on `box`."""

    @abstractmethod
    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Learn from the window around `box` with learning rate `rate` (1.0: replace the model)."""

    @abstractmethod
    def failed(self, det: Detection) -> bool:
        """Failure (occlusion) test on the frame's scale-search detection; called once per frame (and,
        with `window_policies`, on other windows too)."""

    @abstractmethod
    def confident(self, det: Detection) -> bool:
        """Update gate: may the model learn from this (non-failed) frame? Once per such frame."""

    @abstractmethod
    def box_model(self, w: float, h: float) -> BoxModel:
        """The Kalman box model of this pipeline for a first box of size w x h."""

    # ------------------------------------------------------------------ detection
    @abstractmethod
    def detect(self, img: np.ndarray, windows: Sequence[Box],
               scales: Sequence[float] | None = None) -> list[Detection]:
        """One detection per window (its `scale` copied from `scales`, 1.0 without)."""

    @abstractmethod
    def detect_scales(self, img: np.ndarray, windows: Sequence[Box], scales: Sequence[float], penalty: float,
                      climb: bool, floor: float = 0.0) -> tuple[list[Detection], int, int]:
        """The scale search at the prediction: windows of sizes `scales` x the predicted size (the middle
        one the prediction). Returns (detections, best, first): the detections of windows[first:first +
        len(detections)], and the index of the winner among them (the largest peak x penalty^|k|, k steps
        from the middle). `climb` and `floor`: ScaleSearchParams. A filter with its own scale estimate
        (`own_scale`) answers with one detection whose `scale` is its estimate."""

    def detect_grid(self, img: np.ndarray, window: Box, overlap: float, scale: float = 1.0,
                    skip_centre: bool = True) -> tuple[list[Detection], list[Box]]:
        """The papers' 3x3 re-detection grid around `window` (windows overlapping by `overlap`; paper 000
        Sec. III-B.4): detections of the kept windows (the centre left out if `skip_centre`), all 9."""
        wins = grid_windows(window, overlap)
        keep = [w for k, w in enumerate(wins) if not (skip_centre and k == 4)]
        return self.detect(img, keep, [scale] * len(keep)), wins

    def detect_lattice(self, img: np.ndarray, window: Box, step: float, rings: int, scale: float = 1.0,
                       half: tuple[int, int] | None = None, centre: bool = False,
                       channels: int = 0) -> tuple[list[Detection], list[Box]]:
        """The re-detection lattice (ours): (2 rings + 1)^2 windows `step` x the window apart around
        `window`, those centred in the image, the centre only if `centre`; with `half` = (ring r, parity),
        rings r and beyond only where (i + j) % 2 == parity. `channels`: a filter's optional screen on
        principal channels (unused here). Returns the detections and their windows."""
        ih, iw = img.shape[:2]  # an ndarray or a SmoothedFrame
        wins = []
        for j in range(-rings, rings + 1):
            for i in range(-rings, rings + 1):
                if (i == 0 and j == 0 and not centre) or (
                        half is not None and max(abs(i), abs(j)) >= half[0] and (i + j) % 2 != half[1]):
                    continue
                win = window.shifted(i * step * window.w, j * step * window.h)
                if 0.0 <= win.cx < iw and 0.0 <= win.cy < ih:
                    wins.append(win)
        return self.detect(img, wins, [scale] * len(wins)), wins

    # ------------------------------------------------------------------ long-term memory (LCT style)
    @abstractmethod
    def start_memory(self) -> None:
        """Keep a copy of the first-frame model as the long-term memory of the target (Ma et al.,
        "Long-term correlation tracking", CVPR 2015, Sec. 3.2-3.3)."""

    @abstractmethod
    def memory_score(self, index: int) -> float:
        """The memory's peak on window `index` of the last detection call."""

    @abstractmethod
    def train_memory(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Blend the memory with the target at `box` at the (small) rate `rate`."""

    @abstractmethod
    def memory_as_filter(self) -> contextlib.AbstractContextManager[None]:
        """A context in which detections correlate the long-term memory instead of the model."""

