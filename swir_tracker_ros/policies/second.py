# SPDX-License-Identifier: Apache-2.0
"""`SecondOpinion`: a second Siamese network looks where the leading one looks, on a schedule and whenever
the leader doubts, and a judge picks, per frame, whose box stands (issue 53).

The second network (LightTrack-M next to NanoTrack v3 by default) keeps a template of its own, cut from the
start box, and a state of its own, shifted by the ego motion as the leader's is. When it looks (every
`every` frames of a tracked target, and on every frame whose leader PSR is below `doubt_psr`) it searches
around its own state, and the judge weighs the two answers:

- each opinion's own cues: its score and its score map's PSR, APCE and second peak (policies/gone.py `cues`);
- each one's PSR against its typical PSR (the median over the last `HISTORY` frames it looked on: the two
  networks' maps differ in sharpness, and one target's differ from another's);
- their agreement: the IoU of the two boxes;
- the motion judgement of "No false lock": each box's distance from the Kalman prediction, in target sizes
  (policies/lead.py `off_path`).

The judge is a logistic model of these features (`judge_features`, in that order), P = 1 / (1 + exp(-(w . f
+ b))), the probability that the second's box is the better one; it was fitted on the development set's
frames where the two networks' answers differ (independent runs of each network, the one whose box overlaps
the ground truth more being the better), cross-validated over videos (benchmarks/judge_calibration.py,
docs/experiments.md "Issue 53"). When P exceeds `margin` (and the look-alike guard does not veto it,
policies/lead.py) the second's box stands: it is the frame's box, and each network keeps its own state (with
`lead_follows`, the leader searches again there and takes that answer instead); two boxes that agree
(`agree_iou`) are blended (`blend`). Options measured and left off (docs/experiments.md): `recentre_iou`, the
second moved onto a standing leader's box when the two disagree; `while_gone`, the second also looks while
the target is gone; `agree_resumes`, two agreeing opinions resume a lost track.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from swir_tracker_ros.core.siamese.params import VERSIONS
from swir_tracker_ros.core.siamese.tracker import SiameseDetection, SiameseTracker
from swir_tracker_ros.paramfield import param
from swir_tracker_ros.policies.gone import GoneCues, cues
from swir_tracker_ros.types import Box

JUDGE_FEATURES = ("log_score_lead", "log_score_second", "log_psr_lead", "log_psr_second", "second_peak_lead",
                  "second_peak_second", "log_apce_lead", "log_apce_second", "off_path_lead",
                  "off_path_second", "agreement", "rel_psr_lead", "rel_psr_second")
"""The judge's features, in the order of its weights (`judge_features`)."""

HISTORY = 30
"""Frames the second looked on whose PSRs make each opinion's typical PSR (the median of their log1p)."""

OFF_PATH_CAP = 5.0
"""Target sizes beyond which a box's distance from the prediction counts as this (a box that far is off the
path either way; the cap keeps one wild answer from dominating the sum)."""


def judge_features(lead: GoneCues, second: GoneCues, agreement: float, off_lead: float, off_second: float,
                   typical: tuple[float | None, float | None] = (None, None)) -> np.ndarray:
    """The judge's features (`JUDGE_FEATURES`) of one frame; `typical`: each opinion's typical log1p PSR
    (None: no history yet, the relative PSR is 0); pure."""
    rel = [0.0 if t is None else math.log1p(max(c.psr, 0.0)) - t for c, t in zip((lead, second), typical)]
    return np.array([
        math.log(min(max(lead.score, 1e-3), 1.0)), math.log(min(max(second.score, 1e-3), 1.0)),
        math.log1p(max(lead.psr, 0.0)), math.log1p(max(second.psr, 0.0)),
        lead.second, second.second,
        math.log1p(max(lead.apce, 0.0)), math.log1p(max(second.apce, 0.0)),
        min(off_lead, OFF_PATH_CAP), min(off_second, OFF_PATH_CAP), agreement, *rel], dtype=np.float64)


def judge(weights: list[float] | tuple[float, ...], features: np.ndarray) -> float:
    """P(the second's box is the better one): the logistic model `weights` (one per feature, then the bias)
    of `features`; pure."""
    w = np.asarray(weights, dtype=np.float64)
    z = float(w[:-1] @ features + w[-1])
    return 1.0 / (1.0 + math.exp(-min(max(z, -50.0), 50.0)))


JUDGE_WEIGHTS = [-1.5758, -13.8554, -0.0878, 0.3427, 0.1188, -0.3020, -0.8847, 0.6986, 0.7425, -1.8555,
                 0.3095, -0.0789, -0.1120, -0.1937]
"""The judge fitted on every video of the development set (NanoTrack v3 leading, LightTrack-M second;
`benchmarks/judge_calibration.py fit`): the second's low score, its distance from the prediction and the
leader's APCE speak for the leader; the second's APCE and PSR and the leader's distance for the second.
Held out over five folds of videos it picks +0.019 (SE 0.007) over LightTrack-M alone (docs/experiments.md
"Issue 53")."""


@dataclass
class SecondParams:
    """(ours, issue 53) The second opinion: its network, when it looks, the judge (policies/second.py)."""

    version: str = param("lighttrack", "the second network (core/siamese/params.py VERSIONS)",
                         choices=tuple(VERSIONS))
    every: int = param(1, "the second network looks every this many frames of a tracked target (1: every "
                          "frame)", 1, 10000)
    doubt_psr: float = param(0.0, "the second also looks on every frame whose leader PSR is below this "
                                  "(0: the schedule only)", 0.0, 1e6)
    weights: list[float] = param(JUDGE_WEIGHTS, "the judge's logistic weights, one per feature of "
                                                "JUDGE_FEATURES then the bias (module docstring)")
    margin: float = param(0.5, "the second's box stands when the judge's P exceeds this", 0.0, 1.0)
    blend: float = param(0.5, "when the two boxes agree (IoU at least `agree_iou`), the frame's box is this "
                              "share of the second's box plus the rest of the leader's (centre and size); 0: "
                              "the standing box alone", 0.0, 1.0)
    agree_iou: float = param(0.5, "the IoU from which the two boxes agree (`blend`)", 0.0, 1.0)
    recentre_iou: float = param(0.0, "when the leader's box stands and the two boxes overlap less than this, "
                                     "the second is moved onto the leader's box; 0: never", 0.0, 1.0)
    while_gone: bool = param(False, "it also looks while the leader's verdict says the target is gone; "
                                    "when its box stands then, that is the frame's box (the state stays "
                                    "the verdict's)")
    agree_resumes: bool = param(False, "while the leader's verdict says gone (and `while_gone`), the track "
                                       "resumes where the two boxes agree (`agree_iou`) when the second's "
                                       "PSR is at least its typical one and the size is the target's")
    lead_follows: bool = param(False, "when the second's box stands, the leader searches again there and "
                                     "takes that answer as its state and the frame's box; False: the frame's "
                                     "box is the second's, the leader keeps its own state")

    def check(self) -> None:
        from swir_tracker_ros.errors import ParameterError

        if len(self.weights) != len(JUDGE_FEATURES) + 1:
            raise ParameterError(f"parameter weights needs {len(JUDGE_FEATURES) + 1} numbers (one per judge "
                                 f"feature, then the bias), got {len(self.weights)}")
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in self.weights):
            raise ParameterError("parameter weights must be finite numbers")


@dataclass(frozen=True)
class Opinion:
    """What the second opinion said on one frame it looked."""

    det: SiameseDetection
    cues: GoneCues
    p: float  # the judge's P(the second's box is the better one)
    stands: bool  # the second's box stands (P > margin)


class SecondOpinion:
    """The second network's template, state and schedule (module docstring)."""

    def __init__(self, p: SecondParams, leader: SiameseTracker) -> None:
        self.p = p
        self.net = SiameseTracker(replace(leader.params, version=p.version, size_gain_power=0.0))
        self._since = 0  # tracked frames since it last looked
        self._psr: tuple[deque[float], deque[float]] = (deque(maxlen=HISTORY), deque(maxlen=HISTORY))

    def start(self, frame: np.ndarray, box: Box, bit_depth: int | None) -> None:
        """The second's template and state from the start box."""
        self.net.init(frame, box, bit_depth)
        self._since = 0
        for h in self._psr:
            h.clear()

    def shift(self, dx: float, dy: float) -> None:
        """The ego motion moves its state as it moves the leader's."""
        cx, cy = self.net.center
        self.net.center = (cx + dx, cy + dy)

    def move(self, box: Box) -> None:
        """Put its state on `box` (the leader's box when they disagree and it stands, with `recentre_iou`; the
        resumed box)."""
        self.net.center, self.net.size = box.center, (box.w, box.h)

    def due(self, lead: GoneCues) -> bool:
        """Whether it looks on this tracked frame: its schedule, or the leader's doubt."""
        self._since += 1
        return self._since >= self.p.every or lead.psr < self.p.doubt_psr

    def confident(self, c: GoneCues) -> bool:
        """The second's PSR of `c` is at least its typical PSR (none yet: not confident)."""
        h = self._psr[1]
        return bool(h) and math.log1p(max(c.psr, 0.0)) >= float(np.median(h))

    def look(self, image: np.ndarray, lead: SiameseDetection, lead_cues: GoneCues,
             off_path: Callable[[Box], float]) -> Opinion:
        """Search around its own state and judge the two answers (module docstring); `off_path` gives a box's
        distance from the prediction in target sizes (policies/lead.py)."""
        self._since = 0
        det = self.net.search(image, *self.net.center, *self.net.size)
        c = cues(det)
        a, b = lead.smoothed, det.smoothed
        agreement = a.iou(b)
        typical = tuple(float(np.median(h)) if h else None for h in self._psr)
        f = judge_features(lead_cues, c, agreement, off_path(a), off_path(b), typical)  # type: ignore[arg-type]
        for h, k in zip(self._psr, (lead_cues, c)):
            if k.psr > 0.0:
                h.append(math.log1p(k.psr))
        prob = judge(self.p.weights, f)
        stands = prob > self.p.margin
        if stands or agreement >= self.p.recentre_iou:
            self.move(b)  # it follows its own answer
        else:
            self.move(a)  # the leader stands and they disagree: it looks where the leader is
        return Opinion(det, c, prob, stands)

    def joined(self, box: Box, opinion: Opinion) -> Box:
        """The frame's box from the leader's `box` and the second's answer (`joined`)."""
        return joined(self.p, box, opinion.det.smoothed, opinion.stands)


def blend(lead: Box, second: Box, share: float) -> Box:
    """`share` of the second's box plus 1 - share of the leader's, centre and size; pure."""
    m = 1.0 - share
    return Box.from_center(m * lead.cx + share * second.cx, m * lead.cy + share * second.cy,
                           m * lead.w + share * second.w, m * lead.h + share * second.h)


def joined(p: SecondParams, box: Box, other: Box, stands: bool) -> Box:
    """The frame's box from the leader's `box` and the second's `other`: the second's when it stands and the
    leader does not follow it (`lead_follows`); their blend when they agree (`blend`, `agree_iou`); pure."""
    if stands and not p.lead_follows:
        box = other
    if p.blend <= 0.0 or box.iou(other) < p.agree_iou:
        return box
    return blend(box, other, p.blend)
