# SPDX-License-Identifier: Apache-2.0
"""MOT metrics and the paper 004 Table 6 style ablation of the acquisition tracker (prints markdown tables).

    .venv/bin/python benchmarks/mot_eval.py            # TUD-Campus (det.txt, HOG, motion) + synthetic
    .venv/bin/python benchmarks/mot_eval.py --quick    # fewer synthetic scenes
    .venv/bin/python benchmarks/mot_eval.py --only tud-det,motion-crowds   # some tables only
Rows: base association (eq. 1 + eq. 2), + engineered edge descriptor (w3 tau), + Siamese score (gamma),
+ both.
Columns: MOTA, MOTP (mean IoU of matches), IDF1, ID switches, and Table 6's "precision" (matched / GT, the
conventional recall) and "recall" (matched / output, the conventional precision); per-frame association time.
tud-det-sweep re-runs the base and paper rows on TUD det.txt over a 3x3 neighbourhood of (r_pos_rel,
gate_chi2) and prints mean, sd and range: how much one setting's score on that short sequence is chance.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import motmetrics as mm
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from swir_tracker_ros.acquisition import crowd  # noqa: E402
from swir_tracker_ros.acquisition.association import Detection  # noqa: E402
from swir_tracker_ros.acquisition.detectors import (  # noqa: E402
    Detector,
    HogPeopleDetector,
    MotDetFile,
    MotionDetector,
)
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker  # noqa: E402
from swir_tracker_ros.acquisition.siamese import SiameseFamily  # noqa: E402
from swir_tracker_ros.types import Box  # noqa: E402

SHARED = REPO.parent / "shared"
TUD = SHARED / "data" / "mot" / "tud_campus"
ABLATION = {
    "base": {"use_edge": False, "use_siamese": False},
    "+ engineered descriptor": {"use_edge": True, "use_siamese": False},
    "+ Siamese": {"use_edge": False, "use_siamese": True},
    "+ both (paper 004)": {"use_edge": True, "use_siamese": True},
}

FAMILIES = ("tud-det", "tud-det-sweep", "tud-motion", "tud-hog", "crossings", "meetings", "crowds",
            "motion-crowds")
# Neighbourhood of the defaults for the TUD det.txt sensitivity table: (r_pos_rel, gate_chi2).
SWEEP = [(r, g) for r in (0.075, 0.08, 0.085) for g in (9.0, 9.21, 9.5)]

Frame = tuple[np.ndarray, list[tuple[int, Box]]]  # image, ground truth (id, box)


@dataclass
class Result:
    mota: float
    motp: float
    idf1: float
    idsw: int
    recall: float
    precision: float
    assoc_ms: float
    frames: int


def tud_frames(seq: Path = TUD) -> Iterator[Frame]:
    """TUD-Campus frames (gray) with their ground truth (MOT 1-based boxes made 0-based)."""
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    n = int(rows[:, 0].max())
    for f in range(1, n + 1):
        img = cv2.imread(str(seq / f"{f:06d}.png"), cv2.IMREAD_GRAYSCALE)
        gt = [(int(r[1]), Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5])) for r in rows[rows[:, 0] == f]]
        yield img, gt


def crowd_frames(scene: crowd.CrowdScene, frames: int, min_visibility: float = 0.25) -> Iterator[Frame]:
    for k in range(frames):
        img, gts = crowd.render(scene, k)
        yield img, [(g.id, g.box) for g in gts if g.visible_fraction >= min_visibility]


class SimulatedDetector:
    """Ground-truth-based detector stand-in for synthetic scenes (misses, jitter, false positives)."""

    def __init__(self, scene: crowd.CrowdScene, seed: int) -> None:
        self.scene, self.seed = scene, seed
        self.reset()

    def reset(self) -> None:
        self.k = 0
        self.rng = np.random.default_rng(self.seed)

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        _, gts = crowd.render(self.scene, self.k)
        self.k += 1
        return crowd.simulated_detections(gts, self.rng, size=(self.scene.width, self.scene.height))


def iou_distance(gt: list[Box], hyp: list[Box], max_d: float = 0.5) -> np.ndarray:
    """1 - IoU, NaN (no match allowed) above max_d: motmetrics' iou_matrix, which uses np.asfarray
    (removed in NumPy 2) in motmetrics 1.4.0."""
    d = np.array([[1.0 - g.iou(h) for h in hyp] for g in gt]).reshape(len(gt), len(hyp))
    d[d > max_d] = np.nan
    return d


def evaluate(frames: Iterable[Frame], detector: Detector, tracker: MultiTargetTracker | None) -> Result:
    """Run detector (+ tracker) over frames and score with motmetrics (IoU distance, match at IoU >= 0.5).
    Without a tracker the raw detections are scored (each gets a fresh ID: IDF1/IDSW meaningless)."""
    acc = mm.MOTAccumulator(auto_id=True)
    times = []
    n = 0
    fresh = 10**6
    for img, gt in frames:
        dets = detector.detect(img)
        if tracker is None:
            hyp = []
            for d in dets:
                fresh += 1
                hyp.append((fresh, d.box))
        else:
            tracks = tracker.step(img, dets)
            times.append(tracker.last_timing_s)
            hyp = [(t.id, t.box) for t in tracks]
        dist = iou_distance([b for _, b in gt], [b for _, b in hyp])
        acc.update([i for i, _ in gt], [i for i, _ in hyp], dist)
        n += 1
    mh = mm.metrics.create()
    s = mh.compute(acc, metrics=["mota", "motp", "idf1", "num_switches", "recall", "precision"], name="x")
    row = s.loc["x"]
    motp = 1.0 - float(row["motp"]) if np.isfinite(row["motp"]) else 0.0
    return Result(float(row["mota"]), motp, float(row["idf1"]), int(row["num_switches"]),
                  float(row["recall"]), float(row["precision"]),
                  1000.0 * float(np.mean(times)) if times else 0.0, n)


class Replay:
    """The detections of a detector run once over a sequence, replayed (every ablation row sees the same)."""

    def __init__(self, frames: Iterable[Frame], detector: Detector) -> None:
        self.dets = [detector.detect(img) for img, _ in frames]
        self.k = 0

    def reset(self) -> None:
        self.k = 0

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        self.k += 1
        return self.dets[self.k - 1]


def ablation(make_frames: Callable[[], Iterable[Frame]], detector: Detector,
             siamese: SiameseFamily, base: MotParams | None = None,
             rows: dict[str, dict] | None = None) -> dict[str, Result]:
    """One Result per ablation row (plus 'object detector': the detections alone)."""
    base = base or MotParams()
    replay = Replay(make_frames(), detector)
    out = {"object detector": evaluate(make_frames(), replay, None)}
    for name, flags in (rows or ABLATION).items():
        replay.reset()
        params = replace(base, **flags)
        out[name] = evaluate(make_frames(), replay, MultiTargetTracker(params, siamese))
    return out


def sweep(make_frames: Callable[[], Iterable[Frame]], detector: Detector, siamese: SiameseFamily,
          rows: tuple[str, ...] = ("base", "+ both (paper 004)")) -> dict[str, list[Result]]:
    """The ablation rows re-run with r_pos_rel and gate_chi2 moved a little around their defaults (SWEEP):
    how much of a difference between two versions is the chaos of one sequence."""
    replay = Replay(make_frames(), detector)
    out: dict[str, list[Result]] = {}
    for name in rows:
        for r_pos, gate in SWEEP:
            replay.reset()
            params = replace(MotParams(), r_pos_rel=r_pos, gate_chi2=gate, **ABLATION[name])
            trk = MultiTargetTracker(params, siamese)
            out.setdefault(name, []).append(evaluate(make_frames(), replay, trk))
    return out


def sweep_table(title: str, res: dict[str, list[Result]]) -> str:
    lines = [f"### {title}", "", "| | MOTA mean +- sd [min, max] | IDF1 mean +- sd [min, max] | IDSW mean |",
             "|---|---|---|---|"]
    for name, rs in res.items():
        cells = []
        for f in ("mota", "idf1"):
            v = 100 * np.array([getattr(r, f) for r in rs])
            cells.append(f"{v.mean():.1f} +- {v.std():.1f} [{v.min():.1f}, {v.max():.1f}]")
        lines.append(f"| {name} | {cells[0]} | {cells[1]} | {np.mean([r.idsw for r in rs]):.1f} |")
    return "\n".join(lines) + "\n"


def pooled(results: list[dict[str, Result]]) -> dict[str, Result]:
    """Frame-weighted mean of several scenes' results (ID switches summed)."""
    out = {}
    for key in results[0]:
        rs = [r[key] for r in results]
        w = np.array([r.frames for r in rs], float)
        avg = {f: float(np.average([getattr(r, f) for r in rs], weights=w))
               for f in ("mota", "motp", "idf1", "recall", "precision", "assoc_ms")}
        out[key] = Result(**avg, idsw=sum(r.idsw for r in rs), frames=int(w.sum()))
    return out


def table(title: str, res: dict[str, Result]) -> str:
    lines = [f"### {title}", "",
             "| | MOTA | MOTP | IDF1 | IDSW | Table-6 precision (=recall) | Table-6 recall (=precision) "
             "| assoc ms/frame |", "|---|---|---|---|---|---|---|---|"]
    for name, r in res.items():
        if name == "object detector":
            lines.append(f"| {name} | - | - | - | - | {100 * r.recall:.2f}% | {100 * r.precision:.2f}% | - |")
        else:
            lines.append(f"| {name} | {100 * r.mota:.2f}% | {100 * r.motp:.2f}% | {100 * r.idf1:.2f}% "
                         f"| {r.idsw} | {100 * r.recall:.2f}% | {100 * r.precision:.2f}% "
                         f"| {r.assoc_ms:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two synthetic scenes per family instead of five")
    ap.add_argument("--no-hog", action="store_true", help="skip HOG on TUD (about 1 s per frame)")
    ap.add_argument("--only", default=",".join(FAMILIES),
                    help=f"comma-separated tables to run (default all): {', '.join(FAMILIES)}")
    args = ap.parse_args(argv)
    only = {f.strip() for f in args.only.split(",") if f.strip()}
    unknown = only - set(FAMILIES)
    if unknown:
        ap.error(f"unknown --only {sorted(unknown)}; choose from {', '.join(FAMILIES)}")
    if args.no_hog:
        only.discard("tud-hog")
    siamese = SiameseFamily.load_default()
    t0 = time.time()
    if "tud-det" in only:
        print(table("TUD-Campus, MOT15 public detections (det.txt)",
                    ablation(lambda: tud_frames(), MotDetFile(TUD / "det.txt"), siamese)))
    if "tud-det-sweep" in only:
        print(sweep_table(f"TUD-Campus det.txt, {len(SWEEP)} settings: r_pos_rel 0.075/0.08/0.085 x "
                          "gate_chi2 9.0/9.21/9.5",
                          sweep(lambda: tud_frames(), MotDetFile(TUD / "det.txt"), siamese)))
    if "tud-motion" in only:
        print(table("TUD-Campus, our motion detector",
                    ablation(lambda: tud_frames(), MotionDetector(), siamese)))
    if "tud-hog" in only:
        print(table("TUD-Campus, our HOG people detector (OpenCV default people SVM)",
                    ablation(lambda: tud_frames(), HogPeopleDetector(), siamese)))
    seeds = range(2 if args.quick else 5)
    if "crossings" in only:
        cross = [ablation(lambda s=s: crowd_frames(crowd.crossing_scene(s), 80),
                          SimulatedDetector(crowd.crossing_scene(s), s), siamese) for s in seeds]
        print(table(f"Synthetic thermal crossings ({len(cross)} scenes x 80 frames), simulated detector",
                    pooled(cross)))
    if "meetings" in only:
        meets = [ablation(lambda s=s: crowd_frames(crowd.meeting_scene(s), 80),
                          SimulatedDetector(crowd.meeting_scene(s), s), siamese) for s in seeds]
        print(table(f"Synthetic thermal meetings: two pedestrians meet and turn back ({len(meets)} scenes x "
                    "80 frames), simulated detector", pooled(meets)))
    if "crowds" in only:
        crowds = [ablation(lambda s=s: crowd_frames(crowd.random_crowd(s, 8), 120),
                           SimulatedDetector(crowd.random_crowd(s, 8), s), siamese) for s in seeds]
        print(table(f"Synthetic thermal crowds ({len(crowds)} scenes x 120 frames, 8 pedestrians), "
                    "simulated detector", pooled(crowds)))
    if "motion-crowds" in only:
        mcrowds = [ablation(lambda s=s: crowd_frames(crowd.random_crowd(s, 8), 120), MotionDetector(),
                            siamese) for s in seeds]
        print(table(f"Synthetic thermal crowds ({len(mcrowds)} scenes), our motion detector",
                    pooled(mcrowds)))
    print(f"total {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
