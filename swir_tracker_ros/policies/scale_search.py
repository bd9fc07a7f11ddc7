# SPDX-License-Identifier: Apache-2.0
"""`ScaleSearch`: the sizes searched at the prediction and the pick among them (paper 000 Sec. III-B.2)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.base import BaseFilter, Detection
from swir_tracker_ros.core.windows import scale_windows
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.occlusion import OcclusionVerdict
from swir_tracker_ros.types import Box


@dataclass
class ScaleSearchParams:
    """Size estimation by correlating windows of several sizes (paper 000: 5 sizes 5 % apart)."""

    step: float = param(0.05, "relative size step of the scale samples (paper 000: 5 %)", 0.0, 0.3)
    n: int = param(5, "scale samples around the predicted size (1, 3 or 5)", 1, 5)
    penalty: float = param(
        0.95,
        "(ours) the peak of a scale sample k steps from the predicted size is weighted by this^|k| when the "
        "best scale is picked (the scale_weight 0.95 of the KCF C++ reference implementation, KCFcpp): a "
        "larger window that takes in more of the target's surroundings must beat the predicted size by "
        "more than its peak noise; 1 (the papers): the largest peak",
        0.5,
        1.0,
    )
    climb: bool = param(
        True,
        "(ours) normal mode correlates the 3 middle scale samples and goes outward one at a time only while "
        "the outermost one is the best (penalised peaks): the same pick as the full search on all but a few "
        "frames, at 3-3.6 windows a frame instead of 5; off (the papers, and always "
        "while re-detecting): every sample",
    )
    climb_ratio: float = param(
        0.9,
        "(ours, climb) a frame whose best peak of the climb is below this x the mean peak of the tracked "
        "frames (and every frame before the first tracked one) correlates every scale sample",
        0.0,
        2.0,
    )
    redetect_scales: float = param(
        1.2,
        "(ours) while re-detecting, the scale search at the prediction gets two more windows, at this factor "
        "and its inverse times the predicted size (penalised as the next scale steps): a size that shrank "
        "while the target was not recognised (a turn, a partial occlusion) can grow back; 0: off",
        0.0,
        3.0,
    )

    def check(self) -> None:
        """Cross-field rules (run by `validate_params` after the fields)."""
        if self.n not in (1, 3, 5):
            raise ParameterError(f"parameter n = {self.n} must be 1, 3 or 5")


@dataclass(frozen=True)
class ScaleResult:
    """The scale search's detections (windows wins, sizes factors: the run that was correlated), the
    winner's index, and the index of the predicted size's window among them."""

    dets: list[Detection]
    best: int
    wins: list[Box]
    factors: tuple[float, ...]
    mid: int


class ScaleSearch:
    """Windows of several sizes at the prediction; the best penalised peak wins."""

    def __init__(self, p: ScaleSearchParams) -> None:
        self.p = p
        half = p.n // 2
        self.normal = tuple(1.0 + p.step * i for i in range(-half, half + 1))  # e.g. (0.90, ..., 1.10)

    def factors(self, base: BaseFilter, occluded: int) -> tuple[float, ...]:
        """Sizes searched at the prediction: the normal ones, and while re-detecting (`redetect_scales`,
        the scale search) 1 / redetect_scales and redetect_scales at either end (ours).

        A target that turns or is partly hidden is no longer recognised at its size, and the 5-scale
        search (+-10 %, each step penalised) lets the size drift down with the weaker peaks: on OTB girl
        the box shrank to half the girl while she turned away, and a filter correlating a window of that
        size never found her again. The two wide windows let one re-detection frame recover 20 %.
        """
        factors, r = self.normal, self.p.redetect_scales
        if r > 0.0 and len(factors) > 1 and occluded > 0 and not base.own_scale:
            factors = (1.0 / r, *factors, r)
        return factors

    def search(self, base: BaseFilter, img: np.ndarray, pred: Box, verdict: OcclusionVerdict) -> ScaleResult:
        """The normal-mode search at the prediction `pred` (`BaseFilter.detect_scales`)."""
        factors = self.factors(base, verdict.occluded)
        wins = scale_windows(pred.cx, pred.cy, pred.w, pred.h, base.padding, factors)
        climb = self.p.climb and verdict.occluded == 0
        floor = verdict.mean_bar(self.p.climb_ratio, math.inf)
        dets, best, lo = base.detect_scales(img, wins, factors, self.p.penalty, climb, floor)
        mid = len(wins) // 2 - lo
        return ScaleResult(dets, best, wins[lo : lo + len(dets)], factors[lo : lo + len(dets)], mid)
