# SPDX-License-Identifier: Apache-2.0
"""`GoneVerdict`: is the Siamese network's target gone on this frame? A pure, stateful judge of one
`SiameseDetection` a frame, for the network that never says so itself (docs/siamese.md).

The rule: gone when the score map's PSR at the chosen point is below `psr_gone` (3.5) or the chosen point's
foreground probability below `score_gone` (0.7); after a gone frame, found again only when the PSR reaches
`psr_resume` (40): a hysteresis, since the network that has slipped off its target keeps maps of PSR up to
~70 on the background (95th percentile of its IoU < 0.1 frames) where a well-tracked target's median is
~1400 (v3) or ~80 (v2).
Its state is the last verdict and the typical PSR of the tracked frames (for `psr_drop`, `resume_ratio`).

Calibrated (benchmarks/gone_cues.py, benchmarks/gone_calibration.py; docs/experiments.md "Gone verdict for
the network") on the development set, the 24 shared sequences and the 46 built corpus sequences (70
sequences, 57 videos, 16954 frames 2..N), with `SiameseTracker` v2 and v3 alone (OPE, its own state),
label gone = absent in gt.txt or IoU < 0.1: the largest recall of gone with at most 0.5 % of the frames
with IoU >= 0.5 said gone (mean over videos), v2 and v3 pooled; cross-validated in 5 folds grouped by video
(no constant scored on a video it was fitted on): psr_gone 3.5 in every fold of both versions. Held-out,
pooled: precision 0.85, recall 0.60 (v3 0.76, v2 0.42), 1.1 % of IoU >= 0.5 frames said gone (paper 000's
PSR < 7: precision 0.66, recall 0.59, 3.8 %). Logistic rules on 2-4 cues (APCE, second peak, score, mass,
PSR over the recent confident PSRs) were no better held-out at the same cost; a single PSR bar without
hysteresis reaches a third of the recall.

Cues (`cues`, a pure function of one search; the benchmark that calibrated the rule calls the same one):
the score map's PSR at the chosen point (paper 000 eq. 10, the 5 x 5 points around it left out, as
core/siamese/base.py), its APCE (dissertation eq. 4.94), the chosen point's score, penalised score and change
penalty, the map's highest point, the second peak (highest point outside the 5 x 5 around the chosen one)
over the chosen score, the map's mean foreground probability and the displacement of the chosen point from
the searched centre over the search side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.confidence import apce, psr
from swir_tracker_ros.core.siamese.base import PSR_EXCLUSION  # the 5 x 5 points a target's response covers
from swir_tracker_ros.core.siamese.tracker import SiameseDetection
from swir_tracker_ros.paramfield import param


@dataclass(frozen=True)
class GoneCues:
    """The cues of one search (`cues`)."""

    score: float  # foreground probability at the chosen point
    pscore: float  # penalised map at the chosen point
    penalty: float  # change penalty at the chosen point
    peak: float  # highest foreground probability of the map
    psr: float  # PSR of the score map at the chosen point, exclusion 5
    apce: float  # APCE of the score map
    second: float  # highest score outside the 5 x 5 around the chosen point, over the chosen score
    mass: float  # mean foreground probability of the map
    disp: float  # chosen point's distance from the searched centre over the search side (crop pixels)

    def as_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in CUE_NAMES}


CUE_NAMES = ("score", "pscore", "penalty", "peak", "psr", "apce", "second", "mass", "disp")


def second_peak(score_map: np.ndarray, row: int, col: int, exclusion: int = PSR_EXCLUSION) -> float:
    """The highest value of `score_map` outside the `exclusion` x `exclusion` points centred on (row, col)
    (not wrapped: the network's map does not wrap around), over the value at (row, col); 0 when nothing is
    left or the chosen value is 0."""
    h, w = score_map.shape
    half = exclusion // 2
    mask = np.ones((h, w), dtype=bool)
    mask[max(row - half, 0):row + half + 1, max(col - half, 0):col + half + 1] = False
    chosen = float(score_map[row, col])
    if not mask.any() or chosen <= 0.0:
        return 0.0
    return float(score_map[mask].max()) / chosen


def cues(det: SiameseDetection) -> GoneCues:
    """The cues of one search (module docstring); pure."""
    m = np.asarray(det.score_map, dtype=np.float64)
    r, c = det.index
    dx, dy = float(det.boxes.cx[r, c]), float(det.boxes.cy[r, c])
    return GoneCues(
        score=float(det.score), pscore=float(det.pscore), penalty=float(det.penalty), peak=float(m.max()),
        psr=psr(m, r, c, PSR_EXCLUSION), apce=apce(m), second=second_peak(m, r, c),
        mass=float(m.mean()), disp=math.hypot(dx, dy) / float(det.window.out))



@dataclass
class GoneParams:
    """The network's gone verdict: two PSR bars with hysteresis and a score floor (module docstring)."""

    psr_gone: float = param(
        3.5,
        "gone when the score map's PSR at the chosen point (exclusion 5) is below this. Calibrated "
        "(benchmarks/gone_calibration.py, module docstring)",
        0.0,
        1000.0,
    )
    psr_resume: float = param(
        40.0,
        "hysteresis: after a gone frame the target is found again only when the PSR reaches this (a "
        "stricter bar than psr_gone; equal to it: no hysteresis). Calibrated (module docstring)",
        0.0,
        100000.0,
    )
    resume_ratio: float = param(
        0.0,
        "the resume bar is at most this x the typical PSR of this target's tracked frames (the geometric "
        "mean, `history`), never below psr_gone: a target whose maps never stand out much (PSR 10-20 while "
        "tracked well) can be found again; 0: off (psr_resume alone). Measured at 0.5-1.5 (module "
        "docstring): fewer IoU >= 0.5 frames said gone, but also a third less recall; off",
        0.0,
        100.0,
    )
    psr_drop: float = param(
        0.005,
        "also gone when the PSR falls below this x the typical PSR of this target's tracked frames "
        "(`history`): a target hidden behind an occluder leaves maps of PSR 5-10 where it was tracked at "
        "~10^4 (the synthetic scenarios), above `psr_gone`; 0: off. Measured on the dumps of "
        "benchmarks/gone_cues.py (docs/experiments.md): v3 recall 0.73 -> 0.73, absent recall 0.80 -> 0.83, "
        "IoU >= 0.5 frames said gone 0.5 % -> 0.9 %",
        0.0,
        1.0,
    )
    history: int = param(
        25, "frames: the typical PSR is an exponential mean of log PSR over the tracked frames with rate "
        "1 / history", 1, 100000)
    score_gone: float = param(
        0.7,
        "also gone when the chosen point's foreground probability is below this; 0: off. Calibrated "
        "(module docstring)",
        0.0,
        1.0,
    )


class GoneVerdict:
    """Stateful judge of one network search a frame (module docstring): `judge(det)` is True when the
    target is gone on this frame. Its state is whether the last judged frame was gone (the hysteresis);
    `reset()` for a new target."""

    def __init__(self, params: GoneParams | None = None) -> None:
        self.p = GoneParams() if params is None else params
        self.gone = False
        self.typical: float | None = None  # exponential mean of log PSR over the tracked frames

    def reset(self) -> None:
        self.gone = False
        self.typical = None

    def resume_bar(self) -> float:
        """The PSR a frame needs to be found again after a gone frame (GoneParams)."""
        p = self.p
        bar = max(p.psr_resume, p.psr_gone)
        if p.resume_ratio > 0.0 and self.typical is not None:
            bar = min(bar, max(p.psr_gone, p.resume_ratio * math.exp(self.typical)))
        return bar

    def judge_cues(self, c: GoneCues) -> bool:
        """The verdict on one frame's cues (`cues`); remembers it for the next frame's hysteresis and, on a
        tracked frame, updates the typical PSR."""
        bar = self.resume_bar() if self.gone else self.p.psr_gone
        if not self.gone and self.p.psr_drop > 0.0 and self.typical is not None:
            bar = max(bar, self.p.psr_drop * math.exp(self.typical))  # a sudden drop (occlusion)
        self.gone = c.psr < bar or c.score < self.p.score_gone
        if not self.gone:
            lp = math.log(max(c.psr, 1e-6))
            a = 1.0 / self.p.history
            self.typical = lp if self.typical is None else (1.0 - a) * self.typical + a * lp
        return self.gone

    def judge(self, det: SiameseDetection) -> bool:
        """True when the target is gone on the frame of this search."""
        return self.judge_cues(cues(det))
