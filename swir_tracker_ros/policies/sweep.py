# SPDX-License-Identifier: Apache-2.0
"""`LongLossSweep`: after a long loss, a search of the whole image, one tile a frame (ours)."""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.core.windows import scale_windows
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.memory import AppearanceMemory
from swir_tracker_ros.policies.occlusion import OcclusionVerdict
from swir_tracker_ros.policies.redetection import RedetectionParams
from swir_tracker_ros.policies.scale_search import ScaleSearch
from swir_tracker_ros.types import Box


@dataclass
class SweepParams:
    """The long-loss sweep (synthetic t2, x_low_contrast_interlaced; docs/experiments.md, eleventh and
    twelfth passes)."""

    after: int = param(
        25,
        "(ours) frames of re-detection after which every frame that is not `tracking` also searches one "
        "tile of a sweep over the whole image (a lattice_rings lattice, its centre included; each pass from "
        "the tile nearest the prediction outwards), and a prediction that left the image is held at its "
        "border instead of ending the track: a target that turned back or stopped while hidden is found "
        "where the pre-occlusion motion cannot put it. The box moves to a tile's peak only when it and a "
        "window centred on it pass the re-acquisition bars (LCT's re-detection, Ma et al. CVPR 2015 Sec. "
        "3.4); the state turns `tracking` on the next frame's usual checks",
        1,
        100000,
    )


@dataclass(frozen=True)
class Jump:
    """Where the sweep found the target: the detection, its window and the size (w, h) there."""

    det: Detection
    window: Box
    size: tuple[float, float]


class LongLossSweep:
    """One tile of the long-loss sweep over the whole image per frame that is not `tracking`.

    The lattice around the prediction widens to lattice_max_rings and no further; a target that turned
    back or stopped while hidden comes out where the pre-occlusion motion cannot put it (the synthetic t2
    walker turns back behind the occluder and the prediction walks on out of the image). From `after`
    frames of re-detection on, every frame that is not `tracking` also correlates one tile of a raster
    over the image: a lattice of lattice_rings rings (its centre included) of windows of the predicted
    size, one tile a frame, each pass over the image from the tile nearest the prediction outwards (a
    target that stopped or turned back is usually near). The tile is correlated with the long-term memory
    (LCT re-detection, Ma et al. CVPR 2015 Sec. 3.4, which re-detects with a detector trained on confident
    frames only), the bars relative to the memory's mean peak; before the memory has a mean (or without
    one), with the tracking filter, the bars relative to its tracked mean.
    The tile's best peak is a candidate when it lies more than half the box from the prediction (the
    lattice and the normal search looked there), is not failed and reaches reacquire_peak_ratio x the mean
    (with the filter: and beats the lattice's pick `best`). Windows centred on it at the sizes of the
    re-detection's scale search (redetect_scales: a size that drifted while the target was hidden) are
    correlated; the best must pass the bars again and the PSR bar (with the filter: and the memory must
    find the target there). Base filters with a stateless failure test only (`window_policies`: KCF,
    ECO), as the look-alike guard.
    """

    def __init__(self, p: SweepParams, lattice: RedetectionParams) -> None:
        self.p = p
        self.lattice = lattice
        self.tiles: list[tuple[float, float]] = []  # centres of the tiles still to search in this pass

    def active(self, occluded: int) -> bool:
        """Does this frame (`occluded` frames into re-detection) search a tile?"""
        return occluded >= self.p.after

    def restart(self) -> None:
        """The target was tracked: the next loss sweeps from its own prediction outwards."""
        self.tiles.clear()

    def _next_tile(self, img: np.ndarray, pred: Box, window: Box) -> Box:
        """The next tile's window; a new pass over the image starts with the tiles nearest the prediction."""
        lat = self.lattice
        if not self.tiles:
            ih, iw = img.shape
            span = (2 * lat.lattice_rings + 1) * lat.lattice_step
            nx = max(1, math.ceil(iw / (span * window.w)))
            ny = max(1, math.ceil(ih / (span * window.h)))
            tiles = [((i + 0.5) * iw / nx, (j + 0.5) * ih / ny) for j in range(ny) for i in range(nx)]
            self.tiles = sorted(tiles, key=lambda c: -math.hypot(c[0] - pred.cx, c[1] - pred.cy))
        cx, cy = self.tiles.pop()
        return window.shifted(cx - window.cx, cy - window.cy)

    def search(self, base: BaseFilter, img: np.ndarray, pred: Box, window: Box, best: Detection,
               verdict: OcclusionVerdict, memory: AppearanceMemory | None,
               scales: ScaleSearch) -> Jump | None:
        """One tile's search (see the class); `window` is the search window at the prediction, `best` the
        frame's pick so far. Returns where to jump, or None."""
        if not self.active(verdict.occluded):
            return None
        lat, ratio = self.lattice, verdict.p.reacquire_peak_ratio
        tile = self._next_tile(img, pred, window)
        with_memory = memory is not None and memory.peak_n > 0
        bar = memory.mean_bar(ratio) if with_memory else verdict.mean_bar(ratio) if verdict.peak_n else 0.0
        with base.memory_as_filter() if with_memory else contextlib.nullcontext():
            dets, _ = base.detect_lattice(img, tile, lat.lattice_step, lat.lattice_rings, centre=True,
                                          channels=lat.lattice_channels)
            if not dets:
                return None
            cand = max(dets, key=lambda d: d.peak)
            near = abs(cand.cx - pred.cx) <= pred.w / 2 and abs(cand.cy - pred.cy) <= pred.h / 2
            if (near or verdict.failed(cand) or cand.peak < bar
                    or (not with_memory and cand.peak <= best.peak)):
                return None
            factors = scales.factors(base, verdict.occluded)
            wins = scale_windows(cand.cx, cand.cy, pred.w, pred.h, base.padding, factors)
            dets, i, _ = base.detect_scales(img, wins, factors, scales.p.penalty, climb=False)
            det = dets[i]
            if verdict.failed(det) or det.peak < bar or verdict.low_psr(det.psr):
                return None
        if not with_memory and memory is not None and not memory.knows(i):
            return None
        return Jump(det, wins[i], (pred.w * det.scale, pred.h * det.scale))
