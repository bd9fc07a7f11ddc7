# SPDX-License-Identifier: Apache-2.0
"""`Redetection`: the search of a failed frame around the Kalman prediction (paper 000 Sec. III-B.4)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.scale_search import ScaleResult
from swir_tracker_ros.types import Box


@dataclass
class RedetectionParams:
    """Windows around the prediction while the target is not found: the papers' 3x3 grid (windows
    overlapping by a third) or (ours) a denser lattice that widens with the time since the last tracked
    frame."""

    grid_overlap: float = param(
        1.0 / 3.0, "overlap of neighbouring 3x3 grid windows (paper 000: 1/3)", 0.0, 0.9
    )
    grid_scale_search: bool = param(
        False,
        "also search the 5 scales in each of the 9 grid windows (paper 000 text); off: the Kalman size "
        "during re-detection (dissertation), 5x cheaper",
    )
    lattice_step: float = param(
        0.35,
        "(ours) re-detection searches a lattice of windows this fraction of a window apart instead of the "
        "papers' 3x3 grid (steps of 1 - grid_overlap leave gaps a displaced target's cosine-windowed "
        "response cannot bridge); 0: the 3x3 grid (the papers)",
        0.0,
        1.0,
    )
    lattice_rings: int = param(
        2, "(ours) rings of the lattice around the prediction at the start of an occlusion (2: 5x5 windows)",
        1, 10,
    )
    lattice_widen_frames: int = param(
        25,
        "(ours) one more ring every this many frames since the last confident frame, up to "
        "lattice_max_rings (windows outside the image are skipped); 0: no widening",
        0,
        100000,
    )
    lattice_max_rings: int = param(3, "(ours) widest lattice (3: 7x7 windows)", 1, 10)
    lattice_alternate: int = param(
        2,
        "(ours) the lattice's rings from this one outwards are searched as a checkerboard whose two halves "
        "alternate frame to frame (the windows inside it every frame): from ring 2 a 7x7 lattice correlates "
        "28 windows a frame instead of 48; a far target is found at most one frame later; 0: every window "
        "every frame",
        0,
        10,
    )
    lattice_channels: int = param(
        8,
        "(ours) the lattice is screened with the filter projected on this many principal channel directions "
        "of its model (the PCA feature compression of fDSST, Danelljan et al. TPAMI 2017) and only the 3 "
        "best screened windows are correlated in full (KCF filters): occlusion mode faster at scores within "
        "their noise; 0: every window in full",
        0,
        64,
    )
    prior: float = param(
        1.0,
        "(ours, lattice) re-detection picks the window whose peak x exp(-d^2 / 2 sigma^2) is largest, d the "
        "distance of its peak from the prediction and sigma this factor x the lattice's half-width (it "
        "widens with the lattice): a look-alike far away must beat the target's weaker peak near the "
        "prediction by more than the distance costs; 0: the largest peak",
        0.0,
        10.0,
    )


@dataclass(frozen=True)
class Found:
    """The re-detection's pick `det` and the windows it searched (the window at the prediction first)."""

    det: Detection
    windows: tuple[Box, ...]


class Redetection:
    """The windows a failed frame searches and the rule that picks the re-detected target among them."""

    def __init__(self, p: RedetectionParams) -> None:
        self.p = p
        self.lattice = p.lattice_step > 0.0

    def rings(self, occluded: int) -> int:
        """Rings of the lattice: they widen with the frames since the last confident frame."""
        p = self.p
        grow = occluded // p.lattice_widen_frames if p.lattice_widen_frames > 0 else 0
        return max(p.lattice_rings, min(p.lattice_rings + grow, p.lattice_max_rings))

    def search(self, base: BaseFilter, img: np.ndarray, pred: Box, scales: ScaleResult,
               occluded: int) -> Found:
        """Search around the prediction `pred` after the scale search `scales` failed; the normal-mode
        detections stay candidates (the target may still be at the prediction)."""
        p, wins, mid = self.p, scales.wins, scales.mid
        rings = self.rings(occluded) if self.lattice else 0
        if self.lattice:
            half = (p.lattice_alternate, occluded % 2) if p.lattice_alternate > 0 else None
            cand, grid = base.detect_lattice(img, wins[mid], p.lattice_step, rings, half=half,
                                             channels=p.lattice_channels)
            grid = [wins[mid], *grid]
        else:  # one feature computation on the union of the 9 windows (per scale with grid_scale_search)
            cand, grid = base.detect_grid(img, wins[mid], p.grid_overlap)
        if p.grid_scale_search:
            cand = [*scales.dets, *cand]
            for i, f in enumerate(scales.factors):
                if i != mid:
                    cand += base.detect_grid(img, wins[i], p.grid_overlap, scale=f)[0]
        else:
            cand = [scales.dets[mid], *cand]
        det = max(cand, key=self.score(pred, wins[mid], rings))
        return Found(det, tuple(grid))

    def score(self, pred: Box, window: Box, rings: int) -> Callable[[Detection], float]:
        """Ranking of the candidates: the peak, times a Gaussian motion prior (ours, lattice).

        The prior's sigma is `prior` x the lattice's half-width along each axis (`rings` x step x window),
        so it widens with the lattice; `prior` 0 (and the papers' grid): the peak.
        """
        p = self.p
        if not (self.lattice and p.prior > 0.0):
            return lambda d: d.peak
        half = p.prior * rings * p.lattice_step
        sx, sy = half * window.w, half * window.h

        def score(d: Detection) -> float:
            return d.peak * math.exp(-0.5 * (((d.cx - pred.cx) / sx) ** 2 + ((d.cy - pred.cy) / sy) ** 2))

        return score
