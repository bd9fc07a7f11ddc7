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
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import motmetrics as mm
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from swir_tracker_ros.acquisition.association import Detection  # noqa: E402
from swir_tracker_ros.acquisition.detectors import (  # noqa: E402
    Detector,
    HogPeopleDetector,
    MotDetFile,
    MotionDetector,
)
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker, TrackStatus  # noqa: E402
from swir_tracker_ros.acquisition.siamese import SiameseFamily  # noqa: E402
from swir_tracker_ros.scene import crowd  # noqa: E402
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
    causes: dict[str, int] = field(default_factory=dict)  # false output boxes by cause (CAUSES)


# Why an output box is a false positive (motmetrics FP event), checked in this order:
CAUSES = ("tentative", "coasting", "duplicate", "lagging", "false detection")
# tentative: the track is not confirmed; coasting: the track had no detection this frame (its box is the
# prediction); duplicate: the box covers (IoU >= 0.5) a person another output box is matched to; lagging: the
# track's detection this frame covers a person but the output (filtered) box does not; false detection:
# the box follows a detection that covers nobody (a detector false positive or a box at the wrong scale).


@dataclass
class HypInfo:
    """What the scorer needs to know about an output box to give a false positive its cause."""

    tentative: bool = False
    coasting: bool = False
    det_box: Box | None = None  # the detection the track was matched to this frame


Hyp = tuple[int, Box, HypInfo]


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


def score(gts: list[list[tuple[int, Box]]], hyps: list[list[Hyp]], times_s: list[float]) -> Result:
    """motmetrics over a whole run (IoU distance, a match needs IoU >= 0.5) and the cause of every false
    positive output box (CAUSES)."""
    acc = mm.MOTAccumulator(auto_id=True)
    for gt, hyp in zip(gts, hyps):
        acc.update([i for i, _ in gt], [i for i, _, _ in hyp], iou_distance([b for _, b in gt],
                                                                             [b for _, b, _ in hyp]))
    mh = mm.metrics.create()
    s = mh.compute(acc, metrics=["mota", "motp", "idf1", "num_switches", "recall", "precision"], name="x")
    row = s.loc["x"]
    motp = 1.0 - float(row["motp"]) if np.isfinite(row["motp"]) else 0.0
    causes = fp_causes(acc, gts, hyps)
    return Result(float(row["mota"]), motp, float(row["idf1"]), int(row["num_switches"]),
                  float(row["recall"]), float(row["precision"]),
                  1000.0 * float(np.mean(times_s)) if times_s else 0.0, len(gts), causes)


def fp_causes(acc: mm.MOTAccumulator, gts: list[list[tuple[int, Box]]],
              hyps: list[list[Hyp]]) -> dict[str, int]:
    """Count motmetrics' false positives per cause (CAUSES, checked in order)."""
    ev = acc.mot_events
    out = dict.fromkeys(CAUSES, 0)
    if ev.empty:
        return out
    ev = ev.reset_index()
    fps = ev[ev["Type"] == "FP"]
    matched = ev[ev["Type"].isin(["MATCH", "SWITCH"])]
    matched_gt = {(int(f), int(o)) for f, o in zip(matched["FrameId"], matched["OId"])}
    for f, hid in zip(fps["FrameId"], fps["HId"]):
        f = int(f)
        _, box, info = next(h for h in hyps[f] if h[0] == int(hid))
        gt = gts[f]
        if info.tentative:
            cause = "tentative"
        elif info.coasting:
            cause = "coasting"
        elif any(box.iou(g) >= 0.5 and (f, gid) in matched_gt for gid, g in gt):
            cause = "duplicate"
        elif info.det_box is not None and any(info.det_box.iou(g) >= 0.5 for _, g in gt):
            cause = "lagging"
        else:
            cause = "false detection"
        out[cause] += 1
    return out


def evaluate(frames: Iterable[Frame], detector: Detector, tracker: MultiTargetTracker | None) -> Result:
    """Run detector (+ tracker) over frames and score with motmetrics (IoU distance, match at IoU >= 0.5).
    Without a tracker the raw detections are scored (each gets a fresh ID: IDF1/IDSW meaningless)."""
    times: list[float] = []
    gts: list[list[tuple[int, Box]]] = []
    hyps: list[list[Hyp]] = []
    fresh = 10**6
    for img, gt in frames:
        dets = detector.detect(img)
        hyp: list[Hyp] = []
        if tracker is None:
            for d in dets:
                fresh += 1
                hyp.append((fresh, d.box, HypInfo(det_box=d.box)))
        else:
            tracks = tracker.step(img, dets)
            times.append(tracker.last_timing_s)
            for t in tracks:
                info = HypInfo(tentative=t.status is TrackStatus.TENTATIVE, coasting=not t.matched,
                               det_box=t.last_box if t.matched else None)
                hyp.append((t.id, t.output_box, info))
        gts.append(gt)
        hyps.append(hyp)
    return score(gts, hyps, times)


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


PEER_PY = REPO / ".venv-mot" / "bin" / "python"
FRAME_RATE = 25.0  # TUD-Campus (MOT15) frame rate; the peers scale their lost-track buffers by it


def peer_configs() -> list[dict]:
    """The peers of the `trackers` package, each with its defaults and with a small grid over its confidence
    thresholds (the table keeps the defaults and the grid's best, chosen on the table itself: an advantage
    the peers get and our rows do not). Scores reach the peers as our trackers see them, in [0, 1]
    (det.txt: ACF score / 100, clipped)."""
    cfgs = [{"name": "SORT", "tracker": "sort", "kwargs": {}},
            {"name": "ByteTrack", "tracker": "bytetrack", "kwargs": {}},
            {"name": "OC-SORT", "tracker": "ocsort", "kwargs": {}}]
    for a in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5):
        cfgs.append({"name": f"SORT activation {a}", "tracker": "sort",
                     "kwargs": {"track_activation_threshold": a}})
    for a in (0.2, 0.3, 0.4, 0.5):
        for hi in (0.2, 0.3, 0.4, 0.5, 0.6):
            cfgs.append({"name": f"ByteTrack activation {a} high {hi}", "tracker": "bytetrack",
                         "kwargs": {"track_activation_threshold": a, "high_conf_det_threshold": hi}})
    for hi in (0.1, 0.2, 0.3, 0.4, 0.5, 0.6):
        cfgs.append({"name": f"OC-SORT high {hi}", "tracker": "ocsort",
                     "kwargs": {"high_conf_det_threshold": hi}})
    return cfgs


def run_peers(gts: list[list[tuple[int, Box]]], dets: list[list[Detection]]) -> dict[str, Result]:
    """Every peer configuration on the same detections (subprocess in the peer venv), scored by `score`."""
    if not PEER_PY.exists():
        print(f"# peers skipped: {PEER_PY} missing (make mot-venv)", file=sys.stderr)
        return {}
    job = {"frame_rate": FRAME_RATE, "configs": peer_configs(),
           "frames": [[[d.box.x, d.box.y, d.box.w, d.box.h, d.score] for d in fd] for fd in dets]}
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.json", Path(tmp) / "out.json"
        src.write_text(json.dumps(job))
        subprocess.run([str(PEER_PY), str(REPO / "benchmarks" / "mot_peers.py"), str(src), str(dst)],
                       check=True)
        res = json.loads(dst.read_text())
    out = {}
    for name, r in res.items():
        hyps = [[(int(i), Box(x, y, w, h), HypInfo(det_box=Box(x, y, w, h))) for i, x, y, w, h in fr]
                for fr in r["tracks"]]
        out[name] = score(gts, hyps, [])
        out[name].assoc_ms = r["ms"]
    return out


def pick_peers(res: dict[str, Result]) -> dict[str, Result]:
    """Keep our rows, each peer's defaults and each peer's best grid setting (by MOTA, then IDF1)."""
    out = {k: v for k, v in res.items() if not k.startswith(("SORT", "ByteTrack", "OC-SORT"))}
    for peer in ("SORT", "ByteTrack", "OC-SORT"):
        if peer not in res:
            continue
        out[f"{peer} (defaults)"] = res[peer]
        grid = {k: v for k, v in res.items() if k == peer or k.startswith(peer + " ")}
        best = max(grid, key=lambda k: (grid[k].mota, grid[k].idf1))
        if best != peer:
            out[f"{best} (best of {len(grid)})"] = grid[best]
    return out


def ablation(make_frames: Callable[[], Iterable[Frame]], detector: Detector,
             siamese: SiameseFamily, base: MotParams | None = None,
             rows: dict[str, dict] | None = None, peers: bool = True) -> dict[str, Result]:
    """One Result per ablation row (plus 'object detector': the detections alone, and every peer
    configuration on the same detections)."""
    base = base or MotParams()
    replay = Replay(make_frames(), detector)
    out = {"object detector": evaluate(make_frames(), replay, None)}
    for name, flags in (rows or ABLATION).items():
        replay.reset()
        params = replace(base, **flags)
        out[name] = evaluate(make_frames(), replay, MultiTargetTracker(params, siamese))
    if peers:
        out.update(run_peers([gt for _, gt in make_frames()], replay.dets))
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
        causes = {c: sum(r.causes.get(c, 0) for r in rs) for c in CAUSES}
        out[key] = Result(**avg, idsw=sum(r.idsw for r in rs), frames=int(w.sum()), causes=causes)
    return out


def table(title: str, res: dict[str, Result]) -> str:
    res = pick_peers(res)
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
    lines += ["", "False output boxes (motmetrics FP) by cause:", "",
              "| | " + " | ".join(CAUSES) + " | all FP |", "|---|" + "---|" * (len(CAUSES) + 1)]
    for name, r in res.items():
        if name != "object detector":
            lines.append(f"| {name} | " + " | ".join(str(r.causes.get(c, 0)) for c in CAUSES)
                         + f" | {sum(r.causes.values())} |")
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
