# SPDX-License-Identifier: Apache-2.0
"""`ECOBase`: the ECO filter (core/eco/filter.py) as the long-term tracker's base filter.

The tracker's policies drive a base filter through the interface `core/base.py` `BaseFilter`: the scale
search at the prediction (`detect_scales`), detection in other windows (`detect`, the re-detection grid and
lattice), the failure test and the update gate, training on the posterior box, the Kalman box model and the
peak -> Huber threshold map. ECO has its own sample geometry and scale estimate (fDSST), so the windows the
policies hand in are read for their centre and target size only: one ECO detection answers the scale
search (as the DSST option of the correlation filters does), and the re-detection windows are ECO samples
of the current size at the windows' centres, one feature batch.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import math
from collections.abc import Iterator, Sequence

import numpy as np

from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.eco.filter import ECODetection, ECOFilter
from swir_tracker_ros.core.eco.localise import localise
from swir_tracker_ros.core.eco.optimise import scores
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.kalman import PAPER000_KCF, BoxModel, kcf_box_model
from swir_tracker_ros.types import Box


class ECOBase(BaseFilter):
    """ECO as a `BaseFilter` (module docstring).

    Failure (`failed`) tests the detection's PSR against `failure_psr` (paper 000's PSR < 7; docs/eco.md,
    the loss signal) and against a fraction of its recent mean; a failed frame does not teach the filter,
    every other one does (ECO-HC). The Kalman box model is paper 000's (7 states) with its peak -> Huber
    threshold map (eq. 38) and the A4 robust update.
    """

    name = "eco"
    Params = ECOParams
    robust_method = "A4"
    threshold_map = PAPER000_KCF
    psr_reacquisition = False  # re-acquisition's PSR bar was measured on KCF's PSRs
    window_policies = True  # its failure test has no state: the PSR mean moves in `train`
    own_scale = True  # the size comes from ECO's scale estimate, not from windows of several sizes
    learning_rate = 1.0  # ECO learns a new sample at its own weight (ECOParams.learning_rate) or not at all

    def __init__(self, fp: ECOParams, w: float, h: float) -> None:
        self.fp = fp
        self.eco = ECOFilter(fp)
        self.padding = fp.search_area_scale - 1.0  # the windows the policies build: ECO's search area
        self._last: ECODetection | None = None  # the scale search's detection, learnt from by `train`
        self._found: list[ECODetection] = []  # the last detection call's, by window (`memory_score`)
        self.memory: list[np.ndarray] | None = None  # the long-term memory's filter (`start_memory`)
        # PSRs of the last taught frames (the relative failure test)
        self._recent: collections.deque[float] = collections.deque(maxlen=fp.failure_psr_window)

    # ------------------------------------------------------------------ set-up and model
    def initialise(self, img: np.ndarray, box: Box) -> None:
        """Learn the projection and the filter from `box` on the first frame (ECO eq. 4-7)."""
        self.eco.init(img, box)
        self._recent.clear()
        self._last = None

    def box_model(self, w: float, h: float) -> BoxModel:
        return kcf_box_model()

    def failed(self, det: Detection) -> bool:
        """Failure (occlusion) test: the PSR below `failure_psr` (paper 000 eq. 10 and its threshold 7) or
        below `failure_psr_ratio` x the mean PSR of the last `failure_psr_window` frames that taught the
        filter (kept by `train`; no state changes here, so other windows can be tested too)."""
        bar = self.fp.failure_psr
        if self.fp.failure_psr_ratio > 0.0 and self._recent:
            bar = max(bar, self.fp.failure_psr_ratio * sum(self._recent) / len(self._recent))
        return det.psr < bar

    def confident(self, det: Detection) -> bool:
        """Every non-failed frame teaches the filter (ECO-HC; the LMCF gate was measured worse)."""
        return True

    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Learn the frame's scale-search sample, centred on the posterior `box` (ECO Sec. 3.2-3.3: the
        sample space gets it at its own weight; the filter is optimised on its schedule)."""
        if self._last is None:
            return
        self._recent.append(self._last.psr)
        det = dataclasses.replace(self._last, w=box.w, h=box.h)
        self.eco.update(img, det, learn=True, center=(box.cx, box.cy))

    # ------------------------------------------------------------------ detection
    def _target(self, window: Box) -> tuple[float, float, float]:
        """Centre and target width of a policy's window ((1 + padding) x the target)."""
        return window.cx, window.cy, window.w / (1.0 + self.padding)

    def _detection(self, d: ECODetection, scale: float) -> Detection:
        return Detection(d.cx, d.cy, d.peak, d.psr, d.apce, scale, d.window)

    def detect_scales(
        self,
        img: np.ndarray,
        windows: Sequence[Box],
        scales: Sequence[float],
        penalty: float,
        climb: bool,
        floor: float = 0.0,
    ) -> tuple[list[Detection], int, int]:
        """The scale search at the prediction: one ECO detection (translation, then its scale estimate) at
        the middle window's centre and size, answering for every window (the middle one wins)."""
        mid = len(windows) // 2
        cx, cy, w = self._target(windows[mid])
        d = self.eco.detect(img, center=(cx, cy), scale_factor=w / self.eco.geo.base[1])
        self._last, self._found = d, [d] * len(windows)
        det = self._detection(d, scales[mid] * d.scale)
        return [det] * len(windows), mid, 0

    def detect(self, img: np.ndarray, windows: Sequence[Box],
               scales: Sequence[float] | None = None) -> list[Detection]:
        """Translation only, at each window's centre, at the size of the first window's target."""
        if not windows:
            return []
        _, _, w = self._target(windows[0])
        eco = self.eco
        eco.set_target(eco.center[0], eco.center[1], w)
        found = self._found = eco.detect_windows(img, [(b.cx, b.cy) for b in windows])
        factors = scales if scales is not None else [1.0] * len(windows)
        return [self._detection(d, s) for d, s in zip(found, factors)]

    # ------------------------------------------------------------------ long-term memory (LCT style)
    def start_memory(self) -> None:
        """The long-term memory: a copy of the first-frame filter (Ma et al., CVPR 2015, Sec. 3.2-3.3),
        in ECO's projected Fourier domain (the projection P is fixed after the first frame)."""
        self.memory = [hb.copy() for hb in self.eco.hf]

    def memory_score(self, index: int) -> float:
        """The memory's peak on the sample of window `index` of the last detection call."""
        sample = self._found[index].sample
        sf = scores(self.memory, [zb[None] for zb in sample], self.eco.out)
        return localise(sf, self.fp.newton_iterations, 3)[1].value

    def train_memory(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Blend the memory with the filter at the (small) rate `rate`: it follows a lasting change of the
        target's look slowly and only on the frames it verified."""
        self.memory = [(1.0 - rate) * m + rate * hb for m, hb in zip(self.memory, self.eco.hf)]

    @contextlib.contextmanager
    def memory_as_filter(self) -> Iterator[None]:
        """Detections inside the block correlate the long-term memory instead of the filter."""
        eco = self.eco
        eco.hf, self.memory = self.memory, eco.hf
        try:
            yield
        finally:
            eco.hf, self.memory = self.memory, eco.hf

    @property
    def size(self) -> tuple[float, float]:
        """The target size ECO holds (w, h), image pixels."""
        return self.eco.size

    def __repr__(self) -> str:
        w, h = self.eco.size if hasattr(self.eco, "geo") else (math.nan, math.nan)
        return f"ECOBase({w:.1f}x{h:.1f})"
