# SPDX-License-Identifier: Apache-2.0
"""OTB-style one-pass-evaluation metrics: precision and success curves, AUC, centre error, lost frames."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from ..types import Box

PRECISION_THRESHOLDS = np.arange(0, 51, dtype=np.float64)  # pixels, OTB default 0..50
SUCCESS_THRESHOLDS = np.round(np.arange(0, 21) * 0.05, 2)  # IoU 0, 0.05, ..., 1 (21 values)


def center_errors(pred: Sequence[Box | None], gt: Sequence[Box | None]) -> np.ndarray:
    """Euclidean centre distance per frame with ground truth; inf where the tracker gave no box.

    Frames whose ground truth is absent (None) are not scored (they are dropped from the result).
    """
    if len(pred) != len(gt):
        raise ValueError(f"{len(pred)} predictions for {len(gt)} ground-truth frames")
    return np.array([math.inf if p is None or not p.is_finite() else p.center_distance(g)
                     for p, g in zip(pred, gt) if g is not None], dtype=np.float64)


def overlaps(pred: Sequence[Box | None], gt: Sequence[Box | None]) -> np.ndarray:
    """IoU per frame with ground truth; 0 where the tracker gave no box."""
    if len(pred) != len(gt):
        raise ValueError(f"{len(pred)} predictions for {len(gt)} ground-truth frames")
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


def mean_scores(scores: Sequence[Score]) -> Score:
    """Per-sequence mean of the scores and curves (each sequence weighs the same)."""
    if not scores:
        raise ValueError("no scores to average")
    occ = [s.occluded_precision_20 for s in scores if s.occluded_precision_20 is not None]
    fin = [s.center_error for s in scores if math.isfinite(s.center_error)]
    return Score(
        precision_20=float(np.mean([s.precision_20 for s in scores])),
        success_auc=float(np.mean([s.success_auc for s in scores])),
        center_error=float(np.mean(fin)) if fin else math.inf,
        lost_frames=int(sum(s.lost_frames for s in scores)),
        fps=float(np.mean([s.fps for s in scores])),
        frames=int(sum(s.frames for s in scores)),
        occluded_precision_20=float(np.mean(occ)) if occ else None,
        precision_curve=list(np.mean([s.precision_curve for s in scores], axis=0)),
        success_curve=list(np.mean([s.success_curve for s in scores], axis=0)),
    )
