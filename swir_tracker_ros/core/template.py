# SPDX-License-Identifier: Apache-2.0
"""`TemplateFilter`: a base correlation filter on windows resampled to a fixed template, in image coordinates.

The `BaseFilter` (core/base.py) of the correlation filters (core/filters.py: paper 000 KCF, dissertation
DCF-CA, BACF): the template geometry, detection in windows (the 3x3 grid and the lattice from one feature
computation, `MultiWindow`), the scale search and the DSST option, and the long-term memory as a second
filter. Each subclass owns what is specific to it: its Params (`TrackerParams.base`), its filter, its
failure test, its confident-update gate, its peak -> Huber threshold map and its Kalman box model.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
from abc import abstractmethod
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from swir_tracker_ros.core.base import BaseFilter
from swir_tracker_ros.core.confidence import analyse_batch
from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.features import (
    extract_features,
    feature_shape,
    sample_patches,
)
from swir_tracker_ros.core.multiwindow import MultiWindow
from swir_tracker_ros.core.scale import ScaleFilter
from swir_tracker_ros.core.windows import search_window, template_size
from swir_tracker_ros.types import Box


class TemplateFilter(MultiWindow, BaseFilter):
    """A correlation filter working on windows resampled to a fixed template (paper 000 Fig. 3).

    Every search window, whatever its size in the image, is resized to the template size chosen on the
    first frame (halved for large targets, KCF reference), so the filter always sees the same grid.
    Subclasses set `name`, `Params`, `robust_method` and `threshold_map` and implement `_build`, `train`,
    `failed`, `confident` and `box_model`.
    """

    def __init__(self, fp: Any, w: float, h: float) -> None:
        self.fp = fp
        self.kind = fp.feature
        self.cell = 1 if self.kind == "gray" else fp.cell_size
        self.gain = 1.0
        self.exclusion = max(1, math.ceil(fp.psr_exclusion_px / self.cell))
        self.model_scale = (
            0.5 if fp.large_target_halving > 0 and math.sqrt(w * h) >= fp.large_target_halving else 1.0
        )
        self.padding = fp.padding
        self.learning_rate = fp.interp_factor
        self.sizes = fp.fft_sizes  # template cell counts: exact or FFT-friendly (windows.template_size)
        self.tw, self.th = template_size(w, h, self.padding, self.cell, self.model_scale, self.sizes)
        self.shape = feature_shape(self.kind, self.th, self.tw, self.cell)
        self.target_cells = self._target_cells(w, h, w, h)
        self.filter = self._build()
        self.scale_filter: ScaleFilter | None = None  # DSST option (core/scale.py), else the scale search
        if getattr(fp, "scale_estimator", "search") == "dsst":
            self.scale_filter = ScaleFilter(fp.dsst, w, h, soft=self.kind != "hog")
        self._training_memory = False
        self._scratch_buffers: dict[str, np.ndarray] = {}
        self._train_features: tuple[np.ndarray, tuple[Box, ...], np.ndarray] | None = None

    def _target_cells(self, w: float, h: float, tw: float, th: float) -> float:
        """The target's size sqrt(w h) in template cells (the Gaussian label's scale), for a template
        whose exact geometry is (1 + padding) x tw x th: the smooth template's stretch (its cell counts
        over the exact ones, 1 when `fft_sizes` is exact) scales the target with the window."""
        stretch = 1.0
        if self.sizes != "exact":
            ew, eh = template_size(tw, th, self.padding, self.cell, self.model_scale)
            stretch = math.sqrt(self.tw * self.th / (ew * eh))
        return math.sqrt(w * h) * self.model_scale / self.cell * stretch

    @property
    def own_scale(self) -> bool:
        """Does the filter estimate the size itself (DSST) instead of by the scale search's windows?"""
        return self.scale_filter is not None

    @abstractmethod
    def _build(self) -> Any:
        """The filter object for feature maps of `self.shape` and a target of `self.target_cells`."""

    def initialise(self, img: np.ndarray, box: Box) -> None:
        """First-frame training."""
        self.gain = 1.0
        self._train_features = None
        self.train(img, box, 1.0)

    def calibrate_gain(self, img: np.ndarray, box: Box, reference_peak: float) -> None:
        """Scale the responses so that the filter's first-frame self-response at `box` peaks at
        `reference_peak` (0: off); PSR and APCE are scale-invariant (DCF-CA, BACF: their Params)."""
        if reference_peak > 0:
            win = search_window(box.cx, box.cy, box.w, box.h, self.padding)
            self_peak = float(self.filter.respond(self.features(img, [win])).max())
            self.gain = reference_peak / self_peak if self_peak > 1e-12 else 1.0

    def features(self, img: np.ndarray, windows: Sequence[Box]) -> np.ndarray:
        """Windowed feature maps (N, C, rows, cols) of the image regions `windows`."""
        return extract_features(sample_patches(img, windows, self.tw, self.th), self.kind, self.cell)

    def training_features(self, img: np.ndarray, windows: Sequence[Box]) -> np.ndarray:
        """`features` of training windows, computed once per frame for both models: the long-term memory
        (`train_memory`) and the filter train on the same box of the same frame (LCT style), so the
        second call returns the first one's maps (read-only for the filters' `train`). The reuse is
        forgotten at every detection, i.e. on every new frame (a reused frame buffer is never mistaken)."""
        key = tuple(windows)
        cached = self._train_features
        if cached is not None and cached[0] is img and cached[1] == key:
            return cached[2]
        feats = self.features(img, windows)
        self._train_features = (img, key, feats)
        return feats

    def _scratch(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A float32 work array of `shape` reused from frame to frame (fresh multi-MB arrays cost page
        faults on every frame: docs/experiments.md); valid until the next call with the same name."""
        buf = self._scratch_buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = self._scratch_buffers[name] = np.empty(shape, dtype=np.float32)
        return buf

    def detect(
        self,
        img: np.ndarray,
        windows: Sequence[Box],
        scales: Sequence[float] | None = None,
    ) -> list[Detection]:
        """Correlate the filter with each window; the peak displacement is mapped back to image pixels.

        With the DSST scale estimator and several (scale) windows, only the middle window is correlated
        (translation) and the scale filter, centred on its peak, gives the size factor: every entry of
        the returned list is that one detection (same object), so callers indexing by window still work.
        """
        self._train_features = None  # a new frame (training_features)
        if self.scale_filter is not None and len(windows) > 1:
            return self._detect_dsst(img, windows, scales)
        feats = self.features(img, windows)
        # for `memory_score` of the winner (no second feature computation): window i is feats[i]
        self._last_maps = [(feats, i) for i in range(len(windows))]
        responses = self.filter.respond(feats)
        return self._detections(responses, windows, scales if scales is not None else [1.0] * len(windows))

    def detect_scales(self, img: np.ndarray, windows: Sequence[Box], scales: Sequence[float], penalty: float,
                      climb: bool, floor: float = 0.0) -> tuple[list[Detection], int, int]:
        """The scale search at the prediction: (detections, best, first) for the windows `windows` (sizes
        `scales`, the predicted size in the middle). The detections are those of windows[first:first +
        len(detections)], the windows correlated; `best` indexes them: the largest peak x penalty^|k|, k
        steps from the middle window, the first of equals.

        `climb` (ours, `scale_climb`): the middle three windows are correlated, then one more outward at a
        time while the outermost one correlated is the best, as long as there are windows left on that
        side. When the best peak found so far is below `floor`, the remaining windows are correlated too (a
        frame unlike the tracked ones: the peaks over scale need not be unimodal there). The penalty makes
        the search unimodal around the predicted size on most frames (docs/experiments.md).
        """
        n, mid = len(windows), len(windows) // 2

        def best_of(dets: Sequence[Detection], centre: int) -> int:
            return max(range(len(dets)), key=lambda i: dets[i].peak * penalty ** abs(i - centre))

        if not climb or n <= 3 or self.scale_filter is not None:
            dets = self.detect(img, windows, scales)
            return dets, best_of(dets, mid), 0
        lo, hi = mid - 1, mid + 1
        dets = self.detect(img, windows[lo : hi + 1], scales[lo : hi + 1])
        maps = list(self._last_maps)
        best = best_of(dets, 1)
        while (best == 0 and lo > 0) or (best == len(dets) - 1 and hi < n - 1):
            k = lo - 1 if best == 0 else hi + 1
            new = self.detect(img, [windows[k]], [scales[k]])[0]
            if k < lo:
                lo, dets, maps = k, [new, *dets], [*self._last_maps, *maps]
            else:
                hi, dets, maps = k, [*dets, new], [*maps, *self._last_maps]
            best = best_of(dets, mid - lo)
        if dets[best].peak < floor and (lo > 0 or hi < n - 1):
            rest = [*range(lo), *range(hi + 1, n)]
            more = self.detect(img, [windows[k] for k in rest], [scales[k] for k in rest])
            extra = self._last_maps
            dets, maps = [*more[:lo], *dets, *more[lo:]], [*extra[:lo], *maps, *extra[lo:]]
            lo, best = 0, best_of(dets, mid)
        self._last_maps = maps
        return dets, best, lo

    def _detect_dsst(
        self, img: np.ndarray, windows: Sequence[Box], scales: Sequence[float] | None
    ) -> list[Detection]:
        """Translation on the middle window, then the size from the DSST scale filter (core/scale.py)."""
        mid = len(windows) // 2
        base = scales[mid] if scales is not None else 1.0
        win = windows[mid]
        feats = self.features(img, [win])
        self._last_maps = [(feats, 0)] * len(windows)
        det = self._detections(self.filter.respond(feats), [win], [base])[0]
        if self.scale_filter is not None and self.scale_filter.trained:
            k = 1.0 + self.padding  # the window is (1 + padding) x the target
            s = self.scale_filter.estimate(img, det.cx, det.cy, win.w / k, win.h / k)
            det = dataclasses.replace(det, scale=base * s)
        return [det] * len(windows)

    def train_scale(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Train the DSST scale filter (if any) at `box`: rate 1 replaces it, else its own eta (eq. 5).
        Not while the long-term memory learns (`train_memory`): the memory is a translation filter."""
        sf = self.scale_filter
        if sf is None or self._training_memory:
            return
        sf.train(img, box.cx, box.cy, box.w, box.h, 1.0 if rate >= 1.0 else sf.params.learning_rate)

    # ------------------------------------------------------------------ long-term memory (LCT style)
    def start_memory(self) -> None:
        """Keep a copy of the first-frame filter as the long-term memory of the target.

        Ma et al., "Long-term correlation tracking", CVPR 2015, Sec. 3.2-3.3: a second, conservatively
        learnt filter whose response measures the confidence of the tracked box; it learns only from
        frames it finds confident (their eq. 7 threshold), so that a drifting short-term filter cannot
        teach it the background. Here it verifies every `tracking` frame (core_contract.md item 3).
        """
        self.memory = copy.deepcopy(self.filter)

    @contextlib.contextmanager
    def memory_as_filter(self) -> Iterator[None]:
        """Detections inside the block correlate the long-term memory instead of the filter."""
        self.filter, self.memory = self.memory, self.filter
        try:
            yield
        finally:
            self.filter, self.memory = self.memory, self.filter

    def memory_score(self, index: int) -> float:
        """Peak of the memory filter's response on window `index` of the last `detect` call."""
        batch, j = self._last_maps[index]
        z = batch[j : j + 1]
        spectrum = getattr(self.filter, "spectrum", None)  # KCF: the FFT of `detect`, not a second one
        zf = spectrum(batch, j) if spectrum is not None else None
        resp = (self.memory.respond(z) if zf is None else self.memory.respond_spectra(z, zf))[0]
        return float(resp.max()) * self.gain

    def train_memory(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Blend the memory with the window around `box` at the (small) rate `rate`."""
        self.filter, self.memory = self.memory, self.filter
        self._training_memory = True
        try:
            self.train(img, box, rate)
        finally:
            self.filter, self.memory = self.memory, self.filter
            self._training_memory = False

    def _detections(
        self, responses: np.ndarray, windows: Sequence[Box], scales: Sequence[float]
    ) -> list[Detection]:
        if self.gain != 1.0:
            responses = responses * self.gain
        out = []
        peaks = analyse_batch(responses, self.exclusion)  # all windows at once (the lattice has up to 48)
        for win, s, pk in zip(windows, scales, peaks):
            cx = win.cx + pk.col * self.cell * (win.w / self.tw)
            cy = win.cy + pk.row * self.cell * (win.h / self.th)
            out.append(Detection(cx, cy, pk.value, pk.psr, pk.apce, s, win))
        return out
