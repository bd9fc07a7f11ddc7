# SPDX-License-Identifier: Apache-2.0
"""OTB-style one-pass-evaluation metrics: precision and success curves, AUC, centre error, lost frames."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.types import Box

PRECISION_THRESHOLDS = np.arange(0, 51, dtype=np.float64)  # pixels, OTB default 0..50
SUCCESS_THRESHOLDS = np.round(np.arange(0, 21) * 0.05, 2)  # IoU 0, 0.05, ..., 1 (21 values)


FAILED_STATES = frozenset({"lost", "idle"})  # states in which a tracker reports that it has no target


def scored_boxes(pred: Sequence[Box | None], states: Sequence[str]) -> list[Box | None]:
    """The boxes a run is scored with, one rule for every tracker: a frame on which the tracker reports
    failure (state `lost` or `idle`; OpenCV's ok False is stored as `lost`) keeps the last box scored
    before it, as an application keeps showing it. In any other state the reported box is scored; a
    frame without a usable box there (a node that did not answer) scores as no box."""
    if len(pred) != len(states):
        raise HarnessError(f"{len(pred)} boxes for {len(states)} states")
    out: list[Box | None] = []
    last: Box | None = None
    for box, state in zip(pred, states):
        if state in FAILED_STATES:
            out.append(last)
        elif box is not None and box.is_valid():
            out.append(box)
            last = box
        else:
            out.append(None)
    return out


def center_errors(pred: Sequence[Box | None], gt: Sequence[Box | None]) -> np.ndarray:
    """Euclidean centre distance per frame with ground truth; inf where the tracker gave no box.

    Frames whose ground truth is absent (None) are not scored (they are dropped from the result).
    """
    if len(pred) != len(gt):
        raise HarnessError(f"{len(pred)} predictions for {len(gt)} ground-truth frames")
    return np.array([math.inf if p is None or not p.is_finite() else p.center_distance(g)
                     for p, g in zip(pred, gt) if g is not None], dtype=np.float64)


def overlaps(pred: Sequence[Box | None], gt: Sequence[Box | None]) -> np.ndarray:
    """IoU per frame with ground truth; 0 where the tracker gave no box."""
    if len(pred) != len(gt):
        raise HarnessError(f"{len(pred)} predictions for {len(gt)} ground-truth frames")
    return np.array([0.0 if p is None or not p.is_finite() else p.iou(g)
                     for p, g in zip(pred, gt) if g is not None], dtype=np.float64)


def precision_curve(errors: np.ndarray, thresholds: np.ndarray = PRECISION_THRESHOLDS) -> np.ndarray:
    """Fraction of scored frames with centre error <= threshold (OTB precision plot)."""
    if errors.size == 0:
        return np.zeros(len(thresholds))
    return (errors[None, :] <= thresholds[:, None]).mean(axis=1)


def success_curve(ious: np.ndarray, thresholds: np.ndarray = SUCCESS_THRESHOLDS) -> np.ndarray:
    """Fraction of scored frames with IoU > threshold (OTB success plot)."""
    if ious.size == 0:
        return np.zeros(len(thresholds))
    return (ious[None, :] > thresholds[:, None]).mean(axis=1)


def auc(curve: np.ndarray) -> float:
    """Area under the success curve as OTB computes it: the mean over the 21 thresholds."""
    return float(np.mean(curve)) if curve.size else 0.0


@dataclass
class Score:
    """Scores of one tracker on one sequence (or pooled over several)."""

    precision_20: float
    success_auc: float
    center_error: float  # mean over frames where the tracker gave a box (px)
    lost_frames: int  # scored frames with no box or no overlap with the ground truth
    fps: float
    frames: int  # scored frames (ground truth present)
    occluded_precision_20: float | None = None  # precision at 20 px on frames flagged occluded
    precision_curve: list[float] = field(default_factory=list)
    success_curve: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, float | int | None]:
        """The JSON fields of `harness eval` (curves left out)."""
        d = asdict(self)
        d.pop("precision_curve")
        d.pop("success_curve")
        return d


def score(pred: Sequence[Box | None], gt: Sequence[Box | None], seconds: float = 0.0,
          occluded: Sequence[bool | None] | None = None) -> Score:
    """Score one run. `seconds`: tracker time for all frames (fps = frames / seconds)."""
    err = center_errors(pred, gt)
    iou = overlaps(pred, gt)
    pc, sc = precision_curve(err), success_curve(iou)
    finite = err[np.isfinite(err)]
    occ_p20 = None
    if occluded is not None and len(occluded) == len(gt):
        mask = np.array([bool(o) for o, g in zip(occluded, gt) if g is not None], dtype=bool)
        if mask.any():
            occ_p20 = float((err[mask] <= 20.0).mean())
    return Score(
        precision_20=float(pc[20]),
        success_auc=auc(sc),
        center_error=float(finite.mean()) if finite.size else math.inf,
        lost_frames=int(np.sum(~np.isfinite(err) | (iou <= 0.0))),
        fps=len(pred) / seconds if seconds > 0 else 0.0,
        frames=int(err.size),
        occluded_precision_20=occ_p20,
        precision_curve=[float(v) for v in pc],
        success_curve=[float(v) for v in sc],
    )


# --- Spatial robustness (SRE) start boxes --------------------------------------------------------------

SRE_PERTURBATIONS = ("left", "right", "up", "down", "top_left", "top_right", "bottom_left", "bottom_right",
                     "scale_0.8", "scale_0.9", "scale_1.1", "scale_1.2")
SRE_STYLES = ("otb", "shift", "pixel")
PIXEL_SIZE_STEPS = {"scale_0.8": -2, "scale_0.9": -1, "scale_1.1": 1, "scale_1.2": 2}  # style "pixel", px
SRE_SHIFT = 0.1  # shift: 10 % of the target's width / height (Wu et al., CVPR 2013, sec. 3.2)
_DIRECTIONS = {"left": (-1, 0), "right": (1, 0), "up": (0, -1), "down": (0, 1), "top_left": (-1, -1),
               "top_right": (1, -1), "bottom_left": (-1, 1), "bottom_right": (1, 1)}


def _mround(v: float) -> float:
    """Matlab's round (halves away from zero), as the OTB toolkit rounds."""
    return float(math.copysign(math.floor(abs(v) + 0.5), v))


def sre_box(box: Box, perturbation: str, width: int, height: int, style: str = "otb") -> Box:
    """The start box of one SRE run (Wu, Lim, Yang, "Online Object Tracking: A Benchmark", CVPR 2013).

    OTB's spatial robustness evaluation starts each sequence 12 times: "8 spatial shifts including 4 center
    shifts and 4 corner shifts, and 4 scale variations. The amount for shift is 10 % of target size, and the
    scale ratio varies among 0.8, 0.9, 1.1 and 1.2 to the ground truth."

    style "otb" is the benchmark toolkit's `shiftInitBB`, in 0-based pixels: the 4 centre shifts move the box
    by ceil(0.1 w) / ceil(0.1 h); the 4 corner shifts move ONE corner outwards by round(0.1 w), round(0.1 h)
    with the opposite corner fixed (the box grows by ~10 % per axis); the scales keep the centre and round
    x, y, w, h. style "shift" reads the paper literally: the whole box moves by (+-0.1 w, +-0.1 h) in 8
    directions, without rounding. style "pixel" (ours) asks whether the tracker gives the same answer when
    the start box moves by a pixel: the 8 directions move it by 1 px, and the 4 scales change its width and
    height by -2, -1, +1, +2 px about its centre (`PIXEL_SIZE_STEPS`); a stable tracker's spread is then
    close to 0. All styles clip as the toolkit does: a negative x or y becomes 0 with the size
    kept (the box moves), then a box reaching past the right or bottom edge is cut there.
    """
    if style not in SRE_STYLES:
        raise HarnessError(f"SRE style {style!r}; choose from {', '.join(SRE_STYLES)}")
    x, y, w, h = box.as_tuple()
    if style == "pixel" and perturbation != "none":
        if perturbation in _DIRECTIONS:
            sx, sy = _DIRECTIONS[perturbation]
            x, y = x + sx, y + sy
        elif perturbation in PIXEL_SIZE_STEPS:
            d = PIXEL_SIZE_STEPS[perturbation]
            x, y, w, h = x - d / 2.0, y - d / 2.0, w + d, h + d
        else:
            raise HarnessError(f"unknown SRE perturbation {perturbation!r}")
    elif perturbation.startswith("scale_"):
        r = float(perturbation.removeprefix("scale_"))
        cx, cy = x + w / 2.0, y + h / 2.0
        nw, nh = r * w, r * h
        x, y, w, h = (_mround(v) for v in (cx - nw / 2.0, cy - nh / 2.0, nw, nh))
    elif perturbation in _DIRECTIONS:
        sx, sy = _DIRECTIONS[perturbation]
        if style == "shift":
            x, y = x + sx * SRE_SHIFT * w, y + sy * SRE_SHIFT * h
        elif sx == 0 or sy == 0:  # toolkit centre shifts: ceil
            x, y = x + sx * math.ceil(SRE_SHIFT * w), y + sy * math.ceil(SRE_SHIFT * h)
        else:  # toolkit corner shifts: one corner moves, the opposite one stays
            x1, y1 = x + w, y + h  # exclusive right / bottom edge (= toolkit's br + 1)
            if sx < 0:
                x = _mround(x - SRE_SHIFT * w)
            else:
                x1 = _mround(x1 - 1 + SRE_SHIFT * w) + 1
            if sy < 0:
                y = _mround(y - SRE_SHIFT * h)
            else:
                y1 = _mround(y1 - 1 + SRE_SHIFT * h) + 1
            w, h = x1 - x, y1 - y
    elif perturbation != "none":
        raise HarnessError(f"unknown SRE perturbation {perturbation!r}")
    if x < 0:
        x = 0.0
    if y < 0:
        y = 0.0
    w, h = min(w, width - x), min(h, height - y)
    return Box(float(x), float(y), float(w), float(h))


def sre_boxes(box: Box, width: int, height: int, style: str = "otb") -> dict[str, Box]:
    """The 12 SRE start boxes by perturbation name (`sre_box`)."""
    return {p: sre_box(box, p, width, height, style) for p in SRE_PERTURBATIONS}


def carry(start: Box, ref: Box, gt: Box) -> Box:
    """`gt` with the offset and scale that `start` has relative to `ref` (ours).

    The centre offset is kept in units of the ground truth's width and height and the size as a ratio per
    axis, so a start 10 % to the left, or 0.8 times the size, of the first ground-truth box stays 10 % to the
    left, or 0.8 times the size, of every later one.
    """
    ox, oy = (start.cx - ref.cx) / ref.w, (start.cy - ref.cy) / ref.h
    rw, rh = start.w / ref.w, start.h / ref.h
    return Box.from_center(gt.cx + ox * gt.w, gt.cy + oy * gt.h, rw * gt.w, rh * gt.h)


def carried_truth(start: Box, ref: Box, gt: Sequence[Box | None]) -> list[Box | None]:
    """The ground truth carried by a perturbed start box (`carry` on every frame with ground truth).

    Two SRE scores follow from it (ours; an SRE start is a different box to track, not the same one drawn
    worse):
    - a run scored against the carried truth measures whether the tracker followed the box it was given,
      whatever its offset and scale; its spread over the starts is the tracker's own sensitivity to the start;
    - the carried truth scored against the ground truth is the score of a tracker that follows the target
      exactly while keeping the start's offset and scale: the spread of that score over the 12 OTB starts
      (about 0.19, set by the 0.8 start's IoU of 0.64 and the 1.1 start's 0.83) is the floor of the plain SRE
      spread for any tracker that does not redraw the box it was given.
    """
    return [None if g is None else carry(start, ref, g) for g in gt]


# --- False tracking and occlusion survival --------------------------------------------------------------

HIDDEN_ABOVE = 0.5  # an occlusion episode: more than half of the in-image silhouette covered ...
MIN_EPISODE_S = 0.2  # ... for at least this long (gaps this short merged)
RECOVERY_S = 1.0  # survived: tracking with IoU > 0 within this long after the target shows again


def false_tracking(states: Sequence[str], pred: Sequence[Box | None], gt: Sequence[Box | None]) -> int:
    """Frames whose reported state is `tracking` while the box does not overlap the ground truth (IoU 0).

    Frames without ground truth are not counted; a `tracking` frame without a box counts (it claims a
    target it cannot show). For OpenCV trackers the harness maps `ok` to `tracking`.
    """
    if not len(states) == len(pred) == len(gt):
        raise HarnessError(f"{len(states)} states, {len(pred)} boxes, {len(gt)} ground-truth frames")
    return sum(1 for s, p, g in zip(states, pred, gt)
               if s == "tracking" and g is not None and (p is None or not p.is_finite() or p.iou(g) <= 0.0))


GONE_STATES = frozenset({"occluded", "lost"})  # states in which a tracker says its target is not visible
FALSE_TRACKING_IOU = 0.1  # a `tracking` frame below this IoU is false tracking (the absent-frame rates)


@dataclass(frozen=True)
class Absence:
    """How a run treats the target's absence, frames after the start only (`absence`).

    absent: frames without ground truth (the target is not visible; gt.txt `0,0,0,0`); gone: of those, the
    frames the tracker said gone (state `occluded` or `lost`). present: frames with ground truth; false_loss:
    of those, the frames said gone; false_tracking: the frames in state `tracking` with IoU < 0.1 (or no
    box)."""

    absent: int = 0
    gone: int = 0
    present: int = 0
    false_loss: int = 0
    false_tracking: int = 0

    @property
    def gone_recall(self) -> float | None:
        """gone / absent (None without absent frames)."""
        return self.gone / self.absent if self.absent else None

    @property
    def false_loss_rate(self) -> float | None:
        return self.false_loss / self.present if self.present else None

    @property
    def false_tracking_rate(self) -> float | None:
        return self.false_tracking / self.present if self.present else None


def absence(states: Sequence[str], pred: Sequence[Box | None], gt: Sequence[Box | None],
            start: int = 0) -> Absence:
    """`Absence` of a run over the frames after `start` (the start frame is no claim of the tracker)."""
    if not len(states) == len(pred) == len(gt):
        raise HarnessError(f"{len(states)} states, {len(pred)} boxes, {len(gt)} ground-truth frames")
    absent = gone = present = lost = false = 0
    for s, p, g in list(zip(states, pred, gt))[start + 1:]:
        if g is None:
            absent += 1
            gone += s in GONE_STATES
            continue
        present += 1
        lost += s in GONE_STATES
        false += s == "tracking" and (p is None or not p.is_finite() or p.iou(g) < FALSE_TRACKING_IOU)
    return Absence(absent, gone, present, lost, false)


def zero_overlap(pred: Sequence[Box | None], gt: Sequence[Box | None]) -> int:
    """Frames with ground truth where the tracker's box (whatever its state) has IoU 0 or is absent."""
    return int(np.sum(overlaps(pred, gt) <= 0.0))


def occlusion_episodes(occlusion: Sequence[float | None], fps: float, hidden_above: float = HIDDEN_ABOVE,
                       min_s: float = MIN_EPISODE_S) -> list[tuple[int, int]]:
    """(first, last) frame of each occlusion episode: runs of frames whose covered share of the in-image
    silhouette exceeds `hidden_above`, gaps up to `min_s` merged, episodes shorter than `min_s` dropped.
    Frames with no value (target out of view) are not hidden. An episode still going on at the last frame,
    or followed by the target out of view, is left out (the target never showed again to be re-acquired).
    The same rules as demo/analysis.occlusion_episodes, on the covered share instead of the visible one.
    """
    hidden = [k for k, o in enumerate(occlusion) if o is not None and o > hidden_above]
    gap = max(1, round(min_s * fps))
    runs: list[list[int]] = []
    for k in hidden:
        if runs and k - runs[-1][1] <= gap:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return [(a, b) for a, b in runs if b - a + 1 >= gap and b + 1 < len(occlusion)
            and occlusion[b + 1] is not None]


def occlusions_survived(episodes: Sequence[tuple[int, int]], states: Sequence[str],
                        pred: Sequence[Box | None], gt: Sequence[Box | None], fps: float,
                        within_s: float = RECOVERY_S) -> int:
    """Episodes after which, within `within_s` of the target showing again, some frame is `tracking`
    with IoU > 0 against the ground truth."""
    n = 0
    for _, b in episodes:
        end = min(len(states), b + 1 + max(1, round(within_s * fps)))
        n += any(states[k] == "tracking" and gt[k] is not None and pred[k] is not None
                 and pred[k].iou(gt[k]) > 0 for k in range(b + 1, end))
    return n
