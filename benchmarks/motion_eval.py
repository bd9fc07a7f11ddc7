# SPDX-License-Identifier: Apache-2.0
"""Recall and precision of the motion detector per frame against ground truth, with the cause of every miss
and every false box (TUD-Campus and the synthetic thermal crowds).

    .venv/bin/python benchmarks/motion_eval.py               # variants table + causes (TUD, crowds)
    .venv/bin/python benchmarks/motion_eval.py --frames      # + the per-frame TUD table of the default
    .venv/bin/python benchmarks/motion_eval.py --offline     # + an offline bound (see below)

A detection matches a ground-truth box at IoU >= 0.5, greedily by IoU, one to one per frame (the rule of
test_acq_detectors); recall = matched / ground truth, precision = matched / detections, over all frames
(warm-up included). Synthetic crowds: `crowd.random_crowd(seed, 8)`, 120 frames, ground truth with at
least 25 % visible (as benchmarks/mot_eval.py).

Rows ("variants") switch the changes of issue 16 off one at a time, so each one's share shows on the real
sequence and on the synthetic crowds alike: "former" is the detector before them (warm-up 5 frames, a
fixed 9 px closing, no ghost test, column split only, of regions wider than 1.5 persons, no bands).
"no bands" is the default of the previous round (no people searched behind the boxes of a region).

--offline adds a row whose background is the median of *all* frames of the sequence, past and future: an
upper bound for a better background model with this segmentation. It is not the runtime path (the node
sees past frames only; an online version would delay every detection by half the window).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from swir_tracker_ros.acquisition.detectors import (  # noqa: E402
    MotionDetector,
    MotionParams,
    greedy_matches,
)
from swir_tracker_ros.scene import crowd  # noqa: E402
from swir_tracker_ros.types import Box  # noqa: E402

TUD = REPO.parent / "shared" / "data" / "mot" / "tud_campus"
VARIANTS = {
    "default": {},
    "no ghost test": {"ghost_speed": 0.0},
    "no head split": {"head_prominence": 1e9},
    "closing 9 px fixed": {"close_rel": 0.0},
    "closing 15 px fixed": {"close_rel": 0.0, "close_size": 15},
    "warm-up 5": {"warmup": 5},
    "no bands (round 2 default)": {"band_min_h": 0.0},
    "bands beside whole boxes": {"band_core": 1.0},
    "bands without the feet test": {"band_same": 0.0},
    "former (issue 16 start)": {"warmup": 5, "close_rel": 0.0, "ghost_speed": 0.0, "head_prominence": 1e9,
                                "split_factor": 1.5, "band_min_h": 0.0},
}
MISS = ("warm-up", "hidden > 50 %", "merged", "split", "part", "too large", "offset", "not found")
FALSE = ("merged group", "part of a person", "too large", "offset", "nobody")
# Misses: warm-up (frame before the first report); hidden > 50 % (more than half the box lies behind
# ground-truth people whose feet are lower, i.e. nearer: one region with them); merged (a box covers 60 % of
# it and of another person); split (two boxes each 60 % inside it); part (one such box); too large (a box
# covers 60 % of it, no other person); offset (a box at IoU 0.2-0.5); not found. False boxes: merged group,
# part of a person, too large, offset, alike; nobody (IoU < 0.2 with everyone: a ghost, shadow, reflection
# or a person the ground truth leaves out, e.g. half outside the image).

Frame = tuple[np.ndarray, list[Box]]


def tud_frames(seq: Path = TUD) -> list[Frame]:
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    return [(cv2.imread(str(seq / f"{f:06d}.png"), cv2.IMREAD_GRAYSCALE),
             [Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5]) for r in rows[rows[:, 0] == f]])
            for f in range(1, int(rows[:, 0].max()) + 1)]


def crowd_frames(seed: int, frames: int = 120) -> Iterator[Frame]:
    scene = crowd.random_crowd(seed, 8)
    for k in range(frames):
        img, gts = crowd.render(scene, k)
        yield img, [g.box for g in gts if g.visible_fraction >= 0.25]


def _inside(a: Box, b: Box) -> float:
    """Fraction of a's area inside b."""
    w = max(0.0, min(a.x + a.w, b.x + b.w) - max(a.x, b.x))
    h = max(0.0, min(a.y + a.h, b.y + b.h) - max(a.y, b.y))
    return w * h / max(a.area, 1e-9)


def match(boxes: list[Box], gt: list[Box]) -> tuple[set[int], set[int]]:
    """Greedy one-to-one matching by IoU (>= 0.5): matched detection and ground-truth indices."""
    return greedy_matches(boxes, gt)


def miss_cause(g: Box, gt: list[Box], boxes: list[Box], warm: bool) -> str:
    hidden = sum(_inside(g, o) for o in gt if o is not g and o.y + o.h > g.y + g.h)
    covering = [b for b in boxes if _inside(g, b) >= 0.6]
    parts = [b for b in boxes if _inside(b, g) >= 0.6 and b.area > 0.1 * g.area]
    if warm:
        return "warm-up"
    if hidden > 0.5:
        return "hidden > 50 %"
    if any(sum(_inside(o, b) >= 0.6 for o in gt) >= 2 for b in covering):
        return "merged"
    if len(parts) >= 2:
        return "split"
    if parts:
        return "part"
    if covering:
        return "too large"
    if any(b.iou(g) > 0.2 for b in boxes):
        return "offset"
    return "not found"


def false_cause(b: Box, gt: list[Box]) -> str:
    if sum(_inside(o, b) >= 0.6 for o in gt) >= 2:
        return "merged group"
    if any(_inside(b, g) >= 0.6 for g in gt):
        return "part of a person"
    if any(_inside(g, b) >= 0.6 for g in gt):
        return "too large"
    if max((b.iou(g) for g in gt), default=0.0) > 0.2:
        return "offset"
    return "nobody"


class Stats:
    def __init__(self) -> None:
        self.tp = self.n_det = self.n_gt = 0
        self.miss: Counter[str] = Counter()
        self.false: Counter[str] = Counter()
        self.per_frame: list[tuple[int, int, int]] = []  # ground truth, detections, matched
        self.ms: list[float] = []

    def add(self, boxes: list[Box], gt: list[Box], warm: bool) -> None:
        ub, ug = match(boxes, gt)
        self.tp += len(ub)
        self.n_det += len(boxes)
        self.n_gt += len(gt)
        self.per_frame.append((len(gt), len(boxes), len(ub)))
        self.miss.update(miss_cause(g, gt, boxes, warm) for j, g in enumerate(gt) if j not in ug)
        self.false.update(false_cause(b, gt) for i, b in enumerate(boxes) if i not in ub)

    @property
    def recall(self) -> float:
        return self.tp / max(self.n_gt, 1)

    @property
    def precision(self) -> float:
        return self.tp / max(self.n_det, 1)


def run(frames: Iterator[Frame] | list[Frame], det: MotionDetector, stats: Stats | None = None) -> Stats:
    stats = stats or Stats()
    for img, gt in frames:
        t0 = time.perf_counter()
        boxes = [d.box for d in det.detect(img)]
        stats.ms.append(1000.0 * (time.perf_counter() - t0))
        stats.add(boxes, gt, det.count <= det.params.warmup)
    return stats


class OfflineBackground(MotionDetector):
    """Offline bound, NOT the runtime path: the background is the median of every frame of the sequence,
    future ones included; everything else (threshold, morphology, ghost test, splitting) as the detector."""

    def __init__(self, frames: list[Frame], params: MotionParams | None = None) -> None:
        super().__init__(replace(params or MotionParams(), warmup=0))
        s = self.params.scale
        stack = [cv2.resize(img, None, fx=s, fy=s, interpolation=cv2.INTER_AREA).astype(np.float32)
                 for img, _ in frames]
        self.whole = np.median(np.stack(stack), axis=0)

    def _background(self, g: np.ndarray) -> np.ndarray:
        self.buffer = [self.whole.copy()]  # the ghost test's absorption must not leak into the bound
        self.background = self.buffer[0].copy()
        return self.whole


def summary_table(rows: dict[str, tuple[Stats, Stats | None]]) -> str:
    lines = ["| variant | TUD recall | TUD precision | crowds recall | crowds precision | ms/frame (TUD) |",
             "|---|---|---|---|---|---|"]
    for name, (tud, crowds) in rows.items():
        c = (f"{100 * crowds.recall:.1f} % | {100 * crowds.precision:.1f} %" if crowds is not None
             else "- | -")
        lines.append(f"| {name} | {100 * tud.recall:.1f} % | {100 * tud.precision:.1f} % | {c} "
                     f"| {np.median(tud.ms):.1f} |")
    return "\n".join(lines) + "\n"


def cause_table(rows: dict[str, Stats]) -> str:
    lines = ["| | matched / GT / detections | misses: " + " | ".join(MISS) + " | false: " + " | ".join(FALSE)
             + " |", "|---|---|" + "---|" * (len(MISS) + len(FALSE))]
    for name, s in rows.items():
        lines.append(f"| {name} | {s.tp} / {s.n_gt} / {s.n_det} | "
                     + " | ".join(str(s.miss.get(c, 0)) for c in MISS) + " | "
                     + " | ".join(str(s.false.get(c, 0)) for c in FALSE) + " |")
    return "\n".join(lines) + "\n"


def frame_table(s: Stats) -> str:
    lines = ["| frame | GT | detections | matched | recall | precision |", "|---|---|---|---|---|---|"]
    for k, (g, d, m) in enumerate(s.per_frame, 1):
        p = f"{100 * m / d:.0f} %" if d else "-"
        lines.append(f"| {k} | {g} | {d} | {m} | {100 * m / max(g, 1):.0f} % | {p} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", action="store_true", help="print the per-frame TUD table of the default")
    ap.add_argument("--offline", action="store_true", help="add the offline whole-sequence-median bound")
    ap.add_argument("--crowds", type=int, default=5, help="synthetic crowd scenes (seeds 0..N-1; 0 = none)")
    ap.add_argument("--variants", default=",".join(VARIANTS), help="comma-separated rows to run")
    args = ap.parse_args(argv)
    names = [v.strip() for v in args.variants.split(",") if v.strip()]
    if unknown := set(names) - set(VARIANTS):
        ap.error(f"unknown variants {sorted(unknown)}; choose from {', '.join(VARIANTS)}")
    t0 = time.time()
    tud = tud_frames()
    rows: dict[str, tuple[Stats, Stats | None]] = {}
    for name in names:
        params = replace(MotionParams(), **VARIANTS[name])
        crowds = None
        if args.crowds:
            crowds = Stats()
            for seed in range(args.crowds):
                run(crowd_frames(seed), MotionDetector(params), crowds)
        rows[name] = (run(tud, MotionDetector(params)), crowds)
    if args.offline:
        rows["offline bound: median of all frames (not online)"] = (run(tud, OfflineBackground(tud)), None)
    print("### Motion detector: recall and precision (IoU >= 0.5, one-to-one per frame)\n")
    print(summary_table(rows))
    print("### Misses and false boxes by cause, TUD-Campus\n")
    print(cause_table({k: v[0] for k, v in rows.items()}))
    if args.crowds:
        print(f"### Misses and false boxes by cause, synthetic crowds ({args.crowds} scenes x 120 frames)\n")
        print(cause_table({k: v[1] for k, v in rows.items() if v[1] is not None}))
    if args.frames and "default" in rows:
        print("### TUD-Campus per frame, default\n")
        print(frame_table(rows["default"][0]))
    print(f"total {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
