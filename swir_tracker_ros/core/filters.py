# SPDX-License-Identifier: Apache-2.0
"""The correlation base filters on a resampled template (`TemplateFilter`): paper 000 KCF, the
dissertation's DCF-CA, BACF; one class each."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from swir_tracker_ros.core.bacf import BACF, BACFParams
from swir_tracker_ros.core.confidence import psr
from swir_tracker_ros.core.dcf_ca import DCFCA, DCFCAParams, context_offsets
from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.features import feature_shape
from swir_tracker_ros.core.kcf import KCF, KCFParams
from swir_tracker_ros.core.template import TemplateFilter
from swir_tracker_ros.core.windows import search_window, template_size
from swir_tracker_ros.kalman import DISSERTATION_DCFCA, PAPER000_KCF, BoxModel, dcfca_box_model, kcf_box_model
from swir_tracker_ros.types import Box


class KCFFilter(TemplateFilter):
    """Paper 000 pipeline: KCF on FHOG (eq. 3-8), PSR failure test, peak-gated update, 7-state box model.

    Failure: PSR < `psr_threshold` (paper 000 eq. 10, threshold 7). Update only when the peak exceeds
    `update_peak_threshold` (0.5). Huber threshold from the peak by eq. 38; robust update A4 (eq. 33-35).
    """

    name = "kcf"
    Params = KCFParams
    robust_method = "A4"
    threshold_map = PAPER000_KCF
    psr_reacquisition = True
    window_policies = True

    def _build(self) -> KCF:
        return KCF(self.fp, self.shape, self.target_cells)

    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        win = search_window(box.cx, box.cy, box.w, box.h, self.padding)
        feats = self.training_features(img, [win])
        if isinstance(self.filter, KCF):  # the memory and the filter learn the same sample on a frame
            if self._sample is None or self._sample[0] is not feats:
                self._sample = (feats, self.filter.sample(feats[0]))
            self.filter.train(feats[0], rate, self._sample[1])
        else:
            self.filter.train(feats[0], rate)
        self.train_scale(img, box, rate)

    def failed(self, det: Detection) -> bool:
        return det.psr < self.fp.psr_threshold

    def __init__(self, fp: KCFParams, w: float, h: float) -> None:
        super().__init__(fp, w, h)
        self._sample: tuple[np.ndarray, tuple[np.ndarray, np.ndarray]] | None = None  # (maps, KCF.sample)
        self._peak_sum = self._apce_sum = 0.0
        self._n = 0
        self._lmcf = fp.update_gate == "lmcf"

    def confident(self, det: Detection) -> bool:
        """Gate `peak`: peak > 0.5 (paper 000). Gate `lmcf` (Wang et al., CVPR 2017, eq. 12): peak >=
        beta1 x mean peak and APCE >= beta2 x mean APCE, the means over the frames that updated."""
        fp = self.fp
        if not self._lmcf:
            return det.peak > fp.update_peak_threshold
        ok = self._n == 0 or (
            det.peak >= fp.lmcf_peak_ratio * self._peak_sum / self._n
            and det.apce >= fp.lmcf_apce_ratio * self._apce_sum / self._n
        )
        if ok:
            self._peak_sum += det.peak
            self._apce_sum += det.apce
            self._n += 1
        return ok

    def box_model(self, w: float, h: float) -> BoxModel:
        return kcf_box_model()


class DCFCAFilter(TemplateFilter):
    """Dissertation pipeline: context-aware DCF (eq. 4.90-4.92), APCE tests (eq. 4.96-4.97), 8-state model.

    Failure: APCE <= `apce_occlusion_ratio` x the mean APCE of every frame so far (eq. 4.96); update only
    when APCE > `apce_update_ratio` x the mean over the non-failed frames (eq. 4.97). Huber threshold from
    the peak by eq. 6.9; robust update A2 (eq. 5.52). Responses are scaled so that the first-frame
    self-response peaks at `reference_peak` (ours; see DCFCAParams).
    """

    name = "dcf_ca"
    Params = DCFCAParams
    robust_method = "A2"
    threshold_map = DISSERTATION_DCFCA

    def __init__(self, fp: DCFCAParams, w: float, h: float) -> None:
        super().__init__(fp, w, h)
        self._apce_sum = self._apce_n = 0.0
        self._apce_est_sum = self._apce_est_n = 0.0

    def _build(self) -> DCFCA:
        return DCFCA(self.fp, self.shape, self.target_cells)

    def initialise(self, img: np.ndarray, box: Box) -> None:
        """First-frame training, then the response gain from the filter's own training sample."""
        super().initialise(img, box)
        self.calibrate_gain(img, box, self.fp.reference_peak)

    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Learn from the window around `box` plus 4 context windows one target size away."""
        win = search_window(box.cx, box.cy, box.w, box.h, self.padding)
        offs = context_offsets(box.w, box.h, self.fp.n_context)
        feats = self.training_features(img, [win, *(win.shifted(dx, dy) for dx, dy in offs)])
        self.filter.train(feats[0], feats[1:], rate)
        self.train_scale(img, box, rate)

    def failed(self, det: Detection) -> bool:
        mean = self._apce_sum / self._apce_n if self._apce_n else 0.0
        occluded = self._apce_n > 0 and det.apce <= self.fp.apce_occlusion_ratio * mean
        self._apce_sum += det.apce  # mean over every frame so far (the thesis does not say which frames)
        self._apce_n += 1
        return occluded

    def confident(self, det: Detection) -> bool:
        mean = self._apce_est_sum / self._apce_est_n if self._apce_est_n else 0.0
        ok = self._apce_est_n == 0 or det.apce > self.fp.apce_update_ratio * mean
        self._apce_est_sum += det.apce
        self._apce_est_n += 1
        return ok

    def box_model(self, w: float, h: float) -> BoxModel:
        return dcfca_box_model(w, h)


class BACFFilter(KCFFilter):
    """Background-aware correlation filter (Kiani Galoogahi et al., ICCV 2017; core/bacf.py) in the KCF
    pipeline's frame: PSR failure test, peak / LMCF update gate, eq. 38 threshold map, 7-state box model
    (inherited from `KCFFilter`).

    The window is (1 + padding) x the target (BACF: 5x), by default made square with the same area
    (`window_shape`), and resampled so that its feature map has at most `max_window_cells` cells (BACF's
    filter_max_area); the filter is the target's size in cells. The tracker hands in proportional
    windows; `features`, `_detections`, `detect_grid` and `detect_lattice` turn each into its square
    (same centre and area), so every pixel <-> cell mapping uses the square. Responses are scaled so
    that the first-frame self-response peaks at `reference_peak` (~1, as KCF's).
    """

    name = "bacf"
    Params = BACFParams
    psr_reacquisition = False  # its flatter responses keep PSRs near 7 on the target
    # its failure test has no state either, but the look-alike guard and the long-loss sweep were never
    # measured on BACF's responses
    window_policies = False

    def __init__(self, fp: BACFParams, w: float, h: float) -> None:
        self._size = (w, h)
        self._square = fp.window_shape == "square"
        self._psr_sum, self._psr_n = 0.0, 0  # PSR of the frames that updated the model (psr_ratio)
        super().__init__(fp, w, h)

    def _window(self, win: Box) -> Box:
        """The window the filter samples for the tracker's (proportional) window `win`."""
        if not self._square or win.w == win.h:
            return win
        side = math.sqrt(win.w * win.h)
        return Box.from_center(win.cx, win.cy, side, side)

    def _build(self) -> BACF:
        fp = self.fp
        w, h = self._size
        tw, th = (math.sqrt(w * h),) * 2 if self._square else (w, h)
        self.tw, self.th = template_size(tw, th, self.padding, self.cell, self.model_scale, self.sizes)
        cells = (self.tw // self.cell) * (self.th // self.cell)
        if cells > fp.max_window_cells:  # BACF filter_max_area: a coarser template, the same window
            self.model_scale *= math.sqrt(fp.max_window_cells / cells)
            self.tw, self.th = template_size(tw, th, self.padding, self.cell, self.model_scale, self.sizes)
        self.shape = feature_shape(self.kind, self.th, self.tw, self.cell)
        self.target_cells = self._target_cells(w, h, tw, th)
        # the smooth template's stretch along each axis (1 when exact) scales the target's support too
        ew, eh = template_size(tw, th, self.padding, self.cell, self.model_scale)
        kx, ky = (self.tw / ew, self.th / eh) if self.sizes != "exact" else (1.0, 1.0)
        support = (
            max(1, math.floor(h * self.model_scale * ky / self.cell)),
            max(1, math.floor(w * self.model_scale * kx / self.cell)),
        )
        return BACF(fp, self.shape, self.target_cells, support)

    def features(self, img: np.ndarray, windows: Sequence[Box]) -> np.ndarray:
        return super().features(img, [self._window(w) for w in windows])

    def _detections(
        self, responses: np.ndarray, windows: Sequence[Box], scales: Sequence[float]
    ) -> list[Detection]:
        dets = super()._detections(responses, [self._window(w) for w in windows], scales)
        k = self.fp.psr_window / (1.0 + self.padding)
        if k <= 0.0 or k >= 1.0:
            return dets
        return [dataclasses.replace(d, psr=self._local_psr(r, k)) for d, r in zip(dets, responses)]

    def _local_psr(self, resp: np.ndarray, k: float) -> float:
        """PSR (paper 000 eq. 10) of the part of `resp` k x its size around the peak (circular)."""
        rows, cols = resp.shape
        r, c = divmod(int(np.argmax(resp)), cols)
        lh, lw = max(5, round(rows * k)), max(5, round(cols * k))
        local = resp[np.ix_((r + np.arange(lh) - lh // 2) % rows, (c + np.arange(lw) - lw // 2) % cols)]
        return psr(local, lh // 2, lw // 2, self.exclusion)

    def detect_grid(
        self, img: np.ndarray, window: Box, overlap: float, scale: float = 1.0, skip_centre: bool = True
    ) -> tuple[list[Detection], list[Box]]:
        return super().detect_grid(img, self._window(window), overlap, scale, skip_centre)

    def detect_lattice(
        self, img: np.ndarray, window: Box, *args: Any, **kwargs: Any
    ) -> tuple[list[Detection], list[Box]]:
        """`BaseFilter.detect_lattice` around the square window of `window`."""
        return super().detect_lattice(img, self._window(window), *args, **kwargs)

    def initialise(self, img: np.ndarray, box: Box) -> None:
        """First-frame training, then the response gain from the filter's own training sample."""
        super().initialise(img, box)
        self.calibrate_gain(img, box, self.fp.reference_peak)

    def failed(self, det: Detection) -> bool:
        """PSR < psr_threshold (paper 000), or (psr_ratio > 0) PSR < psr_ratio x the mean PSR of the
        frames that updated the model: the sharp BACF response keeps a PSR of 7-9 on static structure
        (an occluder's edge) where KCF's falls below 7."""
        if super().failed(det):
            return True
        n = self._psr_n
        return self.fp.psr_ratio > 0.0 and n > 0 and det.psr < self.fp.psr_ratio * self._psr_sum / n

    def confident(self, det: Detection) -> bool:
        ok = super().confident(det)
        if ok:
            self._psr_sum += det.psr
            self._psr_n += 1
        return ok

