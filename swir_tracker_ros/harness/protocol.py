# SPDX-License-Identifier: Apache-2.0
"""The evaluation protocol: how one run is scored (`RunStats.of`) and the one result type (`Results`).

One convention for every tracker, ours and the peers: OPE starts from the ground-truth box of the first
frame with ground truth; SRE (Wu et al., CVPR 2013) from 12 perturbed boxes (`metrics.sre_box`). Every run
is scored on the frames AFTER its start frame (frames 2..N): success AUC over the IoU thresholds
0:0.05:1 and precision at 20 px, a frame on which the tracker reports failure keeping its last box
(`metrics.scored_boxes`); plus false tracking (state `tracking` with IoU 0), frames with IoU 0, and on
synthetic scenarios the occlusions survived. Frames without ground truth (the target is not visible) are
scored apart (`metrics.absence`): AUC and precision are over the frames with ground truth only; on the
absent frames the recall of "gone" (state `occluded` or `lost`), on the present ones the false-loss rate
(said gone) and the false-tracking rate (`tracking` with IoU < 0.1). `Results` holds the scores of stored
runs by sequence, label and start, in groups of sequences (data folders, synthetic scenarios), the video
of each sequence, and computes the per-group means.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, fields

import numpy as np

from swir_tracker_ros.harness.evaluate import OPE, Run
from swir_tracker_ros.harness.metrics import (
    SRE_PERTURBATIONS,
    Absence,
    absence,
    auc,
    carried_truth,
    false_tracking,
    occlusion_episodes,
    occlusions_survived,
    overlaps,
    score,
    scored_boxes,
    success_curve,
    zero_overlap,
)

CURVES = ("precision_curve", "success_curve")


@dataclass
class RunStats:
    """Scores of one run (one tracker, one sequence, one start), frames after the start frame."""

    success_auc: float
    precision_20: float
    false_tracking: int  # state tracking (OpenCV: ok) with IoU 0
    zero_iou: int  # frames with IoU 0 or no box, whatever the state
    frames: int  # scored frames
    fps: float  # frames / tracker seconds (0: not timed)
    occlusions: int = 0  # occlusion episodes after the start (synthetic sources)
    survived: int = 0  # of those, re-acquired within metrics.RECOVERY_S
    carried_auc: float | None = None  # AUC against the truth carried by the start box (metrics.carried_truth)
    floor_auc: float | None = None  # AUC of the carried truth itself: exact tracking of the start's box
    center_error: float | None = None  # mean centre error (px) over frames with a box; None: no such frame
    occluded_precision_20: float | None = None  # precision at 20 px on frames flagged occluded
    absent: int = 0  # frames after the start without ground truth (target not visible; metrics.absence)
    gone: int = 0  # of those, frames the tracker said gone (occluded or lost)
    false_loss: int = 0  # frames with ground truth said gone
    false_tracking_01: int = 0  # frames with ground truth in state tracking with IoU < 0.1
    precision_curve: list[float] = field(default_factory=list, repr=False)
    success_curve: list[float] = field(default_factory=list, repr=False)

    @classmethod
    def of(cls, run: Run, fps: float) -> RunStats:
        """Score `run` by the convention of the module docstring; `fps` is the source's frame rate (for
        the occlusion episodes), not the tracker's speed."""
        pred = scored_boxes(run.pred, run.states) if len(run.states) == len(run.pred) else list(run.pred)
        gt = [g if k > run.init_index else None for k, g in enumerate(run.gt)]
        s = score(pred, gt, run.seconds, run.occluded)
        states = run.states if len(run.states) == len(pred) else ["tracking"] * len(pred)
        episodes: list[tuple[int, int]] = []
        if any(o is not None for o in run.occlusion):
            episodes = [e for e in occlusion_episodes(run.occlusion, fps) if e[0] > run.init_index]
        carried = floor = None
        ref = run.gt[run.init_index] if run.init is not None and run.init_index < len(run.gt) else None
        if ref is not None:
            truth = carried_truth(run.init, ref, gt)
            carried = auc(success_curve(overlaps(pred, truth)))
            floor = auc(success_curve(overlaps(truth, gt)))
        gone = absence(states, pred, run.gt, run.init_index)
        return cls(s.success_auc, s.precision_20, false_tracking(states, pred, gt), zero_overlap(pred, gt),
                   s.frames, s.fps, len(episodes), occlusions_survived(episodes, states, pred, gt, fps),
                   carried, floor, s.center_error if math.isfinite(s.center_error) else None,
                   s.occluded_precision_20, gone.absent, gone.gone, gone.false_loss, gone.false_tracking,
                   s.precision_curve, s.success_curve)

    @property
    def absence_counts(self) -> Absence:
        """The counts of the absent and present frames (`metrics.Absence`: its rates)."""
        return Absence(self.absent, self.gone, self.frames, self.false_loss, self.false_tracking_01)

    @property
    def gone_recall(self) -> float | None:
        return self.absence_counts.gone_recall

    @property
    def false_loss_rate(self) -> float | None:
        return self.absence_counts.false_loss_rate

    @property
    def false_tracking_rate(self) -> float | None:
        return self.absence_counts.false_tracking_rate

    def to_json(self, curves: bool = False) -> dict:
        d = asdict(self)
        d.update(gone_recall=self.gone_recall, false_loss_rate=self.false_loss_rate,
                 false_tracking_rate=self.false_tracking_rate)
        if not curves:
            for c in CURVES:
                d.pop(c)
        return d

    @classmethod
    def from_json(cls, d: dict) -> RunStats:
        known = {f.name for f in fields(cls)}
        return cls(**{k: v for k, v in d.items() if k in known})


def _mean(values: Sequence[float]) -> float:
    return float(np.mean(values))


def standard_error(per_sequence: Sequence[Sequence[float]]) -> float:
    """Standard error of a mean over sequences of means over starts, from the spread between the starts:
    sqrt(sum_s var_s / n_s) / S, with var_s the sample variance of sequence s's n_s values (sequences with
    one value contribute nothing). How far the mean moves when each start is a draw of the same run."""
    terms = [float(np.var(v, ddof=1)) / len(v) for v in per_sequence if len(v) > 1]
    return math.sqrt(sum(terms)) / len(per_sequence) if per_sequence else 0.0


@dataclass
class Results:
    """Scores of stored runs: stats[sequence][label][start], the group of each sequence, per-label meta."""

    stats: dict[str, dict[str, dict[str, RunStats]]] = field(default_factory=dict)
    groups: dict[str, str] = field(default_factory=dict)  # sequence -> data folder, "synthetic", "other"
    videos: dict[str, str] = field(default_factory=dict)  # sequence -> video (devset.video_of)
    labels: list[str] = field(default_factory=list)
    meta: dict = field(default_factory=dict)

    def add(self, sequence: str, label: str, start: str, stats: RunStats) -> None:
        self.stats.setdefault(sequence, {}).setdefault(label, {})[start] = stats
        if label not in self.labels:
            self.labels.append(label)

    def by_group(self) -> dict[str, list[str]]:
        """Sequences by group, groups and sequences in the order first seen."""
        out: dict[str, list[str]] = {}
        for seq in self.stats:
            out.setdefault(self.groups.get(seq, "other"), []).append(seq)
        return out

    def runs(self, seq: str, label: str) -> dict[str, RunStats]:
        return self.stats.get(seq, {}).get(label, {})

    def ope(self, seq: str, label: str) -> RunStats | None:
        return self.runs(seq, label).get(OPE)

    def averaged(self, seq: str, label: str, starts: Sequence[str] | None = None) -> dict[str, float] | None:
        """Means over `starts` (default: every stored start) of AUC and P@20, and how many runs."""
        runs = self.runs(seq, label)
        keys = [k for k in (runs if starts is None else starts) if k in runs]
        if not keys or (starts is not None and len(keys) < len(starts)):
            return None
        return {"success_auc": _mean([runs[k].success_auc for k in keys]),
                "precision_20": _mean([runs[k].precision_20 for k in keys]), "runs": len(keys)}

    def sre(self, seq: str, label: str) -> dict[str, float] | None:
        """SRE of one sequence: AUC mean, min, max, spread over the 12 starts, P@20 mean, the carried and
        floor scores (when every run has them) and the standard error of the AUC mean."""
        runs = self.runs(seq, label)
        aucs = [runs[p].success_auc for p in SRE_PERTURBATIONS if p in runs]
        if not aucs:
            return None
        out = {"mean": _mean(aucs), "min": float(np.min(aucs)), "max": float(np.max(aucs)),
               "spread": float(np.max(aucs) - np.min(aucs)), "runs": len(aucs),
               "precision_20": _mean([runs[p].precision_20 for p in SRE_PERTURBATIONS if p in runs]),
               "se": standard_error([aucs])}
        for key in ("carried_auc", "floor_auc"):
            vals = [getattr(runs[p], key) for p in SRE_PERTURBATIONS if p in runs]
            if all(v is not None for v in vals):
                name = key.removesuffix("_auc")
                out[f"{name}_mean"] = _mean(vals)
                out[f"{name}_spread"] = float(np.max(vals) - np.min(vals))
        return out

    def summary(self, label: str, seqs: Sequence[str]) -> dict:
        """Means over `seqs` (each sequence weighs the same) and sums of frame counts."""
        ope = [r for r in (self.ope(s, label) for s in seqs) if r is not None]
        sre = [v for v in (self.sre(s, label) for s in seqs) if v is not None]
        sre_runs = [r for s in seqs for p, r in self.runs(s, label).items() if p != OPE]
        out: dict = {"sequences": len(seqs)}
        if ope:
            fps = [r.fps for r in ope if r.fps > 0]
            out.update(ope_auc=_mean([r.success_auc for r in ope]),
                       ope_precision_20=_mean([r.precision_20 for r in ope]),
                       ope_false_tracking=sum(r.false_tracking for r in ope),
                       ope_zero_iou=sum(r.zero_iou for r in ope),
                       ope_occlusions=sum(r.occlusions for r in ope),
                       ope_survived=sum(r.survived for r in ope), ope_runs=len(ope),
                       ope_false_loss=_mean([r.false_loss_rate or 0.0 for r in ope]),
                       ope_false_tracking_rate=_mean([r.false_tracking_rate or 0.0 for r in ope]),
                       ope_absent=sum(r.absent for r in ope))
            gone = [r.gone_recall for r in ope if r.gone_recall is not None]
            if gone:  # each sequence with absent frames weighs the same
                out.update(ope_gone_recall=_mean(gone), ope_gone_sequences=len(gone))
            if fps:
                out["fps"] = _mean(fps)
        if sre:
            per_seq = [[r.success_auc for p, r in self.runs(s, label).items() if p in SRE_PERTURBATIONS]
                       for s in seqs]
            out.update(sre_auc=_mean([v["mean"] for v in sre]),
                       sre_precision_20=_mean([v["precision_20"] for v in sre]),
                       sre_spread=_mean([v["spread"] for v in sre]),
                       sre_se=standard_error([v for v in per_seq if v]),
                       **{f"sre_{name}_{stat}": _mean([v[f"{name}_{stat}"] for v in sre])
                          for name in ("carried", "floor") for stat in ("mean", "spread")
                          if all(f"{name}_{stat}" in v for v in sre)},
                       sre_false_tracking=sum(r.false_tracking for r in sre_runs),
                       sre_zero_iou=sum(r.zero_iou for r in sre_runs),
                       sre_occlusions=sum(r.occlusions for r in sre_runs),
                       sre_survived=sum(r.survived for r in sre_runs),
                       sre_runs=len(sre_runs), sre_sequences=len(sre))
        return out

    def to_json(self, curves: bool = False) -> dict:
        return {"labels": self.labels, "meta": self.meta, "groups": self.groups, "videos": self.videos,
                "summary": {g: {t: self.summary(t, s) for t in self.labels}
                            for g, s in self.by_group().items()},
                "sequences": {seq: {t: {k: r.to_json(curves) for k, r in runs.items()}
                                    for t, runs in per.items()} for seq, per in self.stats.items()}}

    @classmethod
    def from_json(cls, data: dict) -> Results:
        """Inverse of `to_json` (the summaries are recomputed)."""
        out = cls(groups=dict(data.get("groups", {})), videos=dict(data.get("videos", {})),
                  labels=list(data["labels"]),
                  meta=dict(data.get("meta", {})))
        for seq, per in data["sequences"].items():
            for label, runs in per.items():
                for start, d in runs.items():
                    out.add(seq, label, start, RunStats.from_json(d))
        return out
