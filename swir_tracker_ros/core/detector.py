# SPDX-License-Identifier: Apache-2.0
"""FilterBank: one correlation filter (KCF or DCF-CA) with its template geometry, in image coordinates."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.confidence import analyse
from swir_tracker_ros.core.dcf_ca import DCFCA, DCFCAParams, context_offsets
from swir_tracker_ros.core.features import (
    cosine_window,
    extract_features,
    feature_shape,
    sample_patch,
    sample_patches,
    unwindowed_features,
)
from swir_tracker_ros.core.kcf import KCF, KCFParams
from swir_tracker_ros.core.params import TrackerParams
from swir_tracker_ros.core.windows import search_window, template_size
from swir_tracker_ros.types import Box


@dataclass(frozen=True)
class Detection:
    """Peak of the response in one search window, mapped to image coordinates."""

    cx: float
    cy: float
    peak: float
    psr: float
    apce: float
    scale: float  # size factor of the window relative to the predicted size
    window: Box


class FilterBank:
    """A correlation filter working on windows resampled to a fixed template (paper 000 Fig. 3).

    Every search window, whatever its size in the image, is resized to the template size chosen on the
    first frame (halved for large targets, KCF reference), so the filter always sees the same grid.
    """

    def __init__(self, p: TrackerParams, w: float, h: float) -> None:
        self.kind = p.feature
        self.cell = 1 if p.feature == "gray" else p.cell_size
        self.gain = 1.0
        self.reference_peak = p.dcf_reference_peak
        self.exclusion = max(1, math.ceil(p.psr_exclusion_px / self.cell))
        self.model_scale = (
            0.5 if p.large_target_halving > 0 and math.sqrt(w * h) >= p.large_target_halving else 1.0
        )
        gray = p.feature == "gray"
        if p.pipeline == "kcf":
            self.padding = p.kcf_padding
            kp = KCFParams(
                padding=p.kcf_padding,
                lambda_=p.kcf_lambda,
                kernel_sigma=p.kcf_kernel_sigma,
                interp_factor=p.kcf_interp_factor,
                output_sigma_factor=p.output_sigma_factor,
                feature=p.feature,
                cell_size=self.cell,
            )
            self.learning_rate = kp.interp_factor
        else:
            self.padding = p.dcf_padding
            dp = DCFCAParams(
                padding=p.dcf_padding,
                lambda1=p.dcf_lambda1,
                lambda2=p.dcf_lambda2,
                interp_factor=p.dcf_interp_factor,
                output_sigma_factor=p.output_sigma_factor,
                feature=p.feature,
                cell_size=self.cell,
            )
            self.learning_rate = dp.interp_factor
        self.tw, self.th = template_size(w, h, self.padding, self.cell, self.model_scale)
        shape = feature_shape(self.kind, self.th, self.tw, self.cell)
        target_cells = math.sqrt(w * h) * self.model_scale / self.cell
        if gray and p.pipeline == "kcf":
            target_cells = math.sqrt(w * h) * self.model_scale
        self.filter: KCF | DCFCA = (
            KCF(kp, shape, target_cells) if p.pipeline == "kcf" else DCFCA(dp, shape, target_cells)
        )

    def features(self, img: np.ndarray, windows: Sequence[Box]) -> np.ndarray:
        """Windowed feature maps (N, C, rows, cols) of the image regions `windows`."""
        return extract_features(sample_patches(img, windows, self.tw, self.th), self.kind, self.cell)

    def initialise(self, img: np.ndarray, box: Box) -> None:
        """First-frame training; DCF-CA also calibrates its response gain on its own training sample."""
        self.gain = 1.0
        self.train(img, box, 1.0)
        if isinstance(self.filter, DCFCA) and self.reference_peak > 0:
            win = search_window(box.cx, box.cy, box.w, box.h, self.padding)
            self_peak = float(self.filter.respond(self.features(img, [win])).max())
            self.gain = self.reference_peak / self_peak if self_peak > 1e-12 else 1.0

    def train(self, img: np.ndarray, box: Box, rate: float) -> None:
        """Learn from the window around `box` (DCF-CA: plus 4 context windows one target size away)."""
        win = search_window(box.cx, box.cy, box.w, box.h, self.padding)
        if isinstance(self.filter, DCFCA):
            offs = context_offsets(box.w, box.h, self.filter.params.n_context)
            feats = self.features(img, [win, *(win.shifted(dx, dy) for dx, dy in offs)])
            self.filter.train(feats[0], feats[1:], rate)
        else:
            self.filter.train(self.features(img, [win])[0], rate)

    def grid_geometry(self, window: Box, overlap: float) -> tuple[int, int, list[Box]]:
        """3x3 re-detection grid around `window` with centre steps snapped to whole template cells.

        The step is (1 - overlap) x window as in `windows.grid_windows`, rounded to whole feature cells of
        the template so that all 9 windows share one pixel and cell lattice (the overlap then differs
        from `overlap` by less than half a cell). Returns (step_x, step_y) in cells and the 9 windows in
        image pixels, row-major, the centre window (index 4) equal to `window`.
        """
        c = self.cell
        sx = max(1, round((1.0 - overlap) * self.tw / c))
        sy = max(1, round((1.0 - overlap) * self.th / c))
        kx, ky = window.w / self.tw, window.h / self.th
        wins = [window.shifted(i * sx * c * kx, j * sy * c * ky) for j in (-1, 0, 1) for i in (-1, 0, 1)]
        return sx, sy, wins

    def grid_features(self, img: np.ndarray, window: Box, overlap: float) -> tuple[np.ndarray, list[Box]]:
        """Windowed feature maps (9, C, rows, cols) of the 3x3 grid, from ONE feature computation.

        The union of the 9 windows is resampled once at the template scale, its features computed once,
        and each window's map cut out of it (the windows sit on whole cells of the union), so the grid
        costs (1 + 2 (1 - overlap))^2 ~ 5.4 windows of features instead of 9.
        """
        sx, sy, wins = self.grid_geometry(window, overlap)
        c = self.cell
        uw, uh = self.tw + 2 * sx * c, self.th + 2 * sy * c
        kx, ky = window.w / self.tw, window.h / self.th
        union = Box.from_center(window.cx, window.cy, uw * kx, uh * ky)
        feats = unwindowed_features(sample_patch(img, union, uw, uh)[None], self.kind, c)[0]
        fh, fw = feature_shape(self.kind, self.th, self.tw, c)[1:]
        win = cosine_window(fh, fw)
        out = np.empty((9, feats.shape[0], fh, fw), dtype=np.float32)
        for k in range(9):  # 9 slices of the union map (steps are whole cells; gray: cell = 1 px)
            r0, c0 = (k // 3) * sy, (k % 3) * sx
            np.multiply(feats[:, r0 : r0 + fh, c0 : c0 + fw], win, out=out[k])
        return out, wins

    def detect_grid(
        self, img: np.ndarray, window: Box, overlap: float, scale: float = 1.0, skip_centre: bool = True
    ) -> tuple[list[Detection], list[Box]]:
        """Detections in the 3x3 re-detection grid around `window` (the centre one left out if asked,
        as normal mode already correlated it) and the 9 grid windows; `scale` is copied to each."""
        feats, wins = self.grid_features(img, window, overlap)
        keep = [k for k in range(9) if not (skip_centre and k == 4)]
        responses = self.filter.respond(feats[keep])
        dets = self._detections(responses, [wins[k] for k in keep], [scale] * len(keep))
        return dets, wins

    def detect(
        self,
        img: np.ndarray,
        windows: Sequence[Box],
        scales: Sequence[float] | None = None,
    ) -> list[Detection]:
        """Correlate the filter with each window; the peak displacement is mapped back to image pixels."""
        responses = self.filter.respond(self.features(img, windows))
        return self._detections(responses, windows, scales if scales is not None else [1.0] * len(windows))

    def _detections(
        self, responses: np.ndarray, windows: Sequence[Box], scales: Sequence[float]
    ) -> list[Detection]:
        if self.gain != 1.0:
            responses = responses * self.gain
        out = []
        for win, s, resp in zip(windows, scales, responses):  # one entry per window (<= 45), not per pixel
            pk = analyse(resp, self.exclusion)
            cx = win.cx + pk.col * self.cell * (win.w / self.tw)
            cy = win.cy + pk.row * self.cell * (win.h / self.th)
            out.append(Detection(cx, cy, pk.value, pk.psr, pk.apce, s, win))
        return out
