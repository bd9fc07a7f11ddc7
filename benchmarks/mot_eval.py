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

The development MOT data (issue 49): TUD-Campus and the windows of the built mot_corpus ($MOT_CORPUS, default
../mot_corpus; ../shared/mot_corpus/README.md), each detector's own boxes (learned YOLOX-Nano, HOG,
motion), cached under --det-cache:

    .venv/bin/python benchmarks/mot_eval.py --only dev-detection,dev-mot --det-cache out/dets
dev-detection: precision / recall of each detector at IoU 0.5 (greedy per frame); dev-mot: our association
and SORT / ByteTrack / OC-SORT on the same boxes, per sequence and averaged per video.
"""

from __future__ import annotations

import argparse
import json
import os
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
    HogParams,
    HogPeopleDetector,
    MotDetFile,
    MotionDetector,
    greedy_matches,
)
from swir_tracker_ros.acquisition.learned import YoloxDetector, model_problem  # noqa: E402
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

DEFAULT_FAMILIES = ("tud-det", "tud-det-sweep", "tud-motion", "tud-hog", "crossings", "meetings", "crowds",
                    "motion-crowds")
FAMILIES = (*DEFAULT_FAMILIES, "dev-detection", "dev-mot")  # the dev tables on request (--only)
CORPUS = Path(os.environ.get("MOT_CORPUS", REPO.parent / "mot_corpus"))
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
    hyps: list[list[tuple[int, Box]]] = field(default_factory=list, repr=False)  # output per frame (HOTA)
    hota: float = float("nan")  # set by `add_hota` (the peer venv's TrackEval-matching HOTA)


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
    """The frames (gray) of a MOT sequence folder (TUD-Campus by default; 000001.png or .jpg ...) with their
    ground truth (MOT 1-based boxes made 0-based)."""
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    ext = ".png" if (seq / "000001.png").is_file() else ".jpg"
    n = len(list(seq.glob(f"[0-9]*{ext}")))
    for f in range(1, n + 1):
        img = cv2.imread(str(seq / f"{f:06d}{ext}"), cv2.IMREAD_GRAYSCALE)
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
                  1000.0 * float(np.mean(times_s)) if times_s else 0.0, len(gts), causes,
                  [[(i, b) for i, b, _ in fr] for fr in hyps])


def add_hota(gts: list[list[tuple[int, Box]]], results: dict[str, Result]) -> None:
    """Set each result's HOTA (benchmarks/mot_peers.py --hota in the peer venv; left NaN without it)."""
    if not PEER_PY.exists():
        return

    def rows(frames: list[list[tuple[int, Box]]]) -> list[list[float]]:
        return [[f + 1, i, *b.as_tuple()] for f, fr in enumerate(frames) for i, b in fr]

    job = {"gt": rows(gts), "runs": {k: rows(r.hyps) for k, r in results.items()}}
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = Path(tmp) / "in.json", Path(tmp) / "out.json"
        src.write_text(json.dumps(job))
        script = str(REPO / "benchmarks" / "mot_peers.py")
        subprocess.run([str(PEER_PY), script, "--hota", str(src), str(dst)], check=True)
        for k, v in json.loads(dst.read_text()).items():
            results[k].hota = v


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

    @classmethod
    def of(cls, dets: list[list[Detection]]) -> Replay:
        """A replay of detections already computed."""
        out = cls([], MotionDetector())
        out.dets = dets
        return out

    def reset(self) -> None:
        self.k = 0

    def detect(self, frame: np.ndarray, ego_shift: tuple[float, float] = (0.0, 0.0)) -> list[Detection]:
        self.k += 1
        return self.dets[self.k - 1]


PEER_PY = Path(os.environ.get("MOT_PEER_PYTHON", REPO / ".venv-mot" / "bin" / "python"))
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


def run_peers(gts: list[list[tuple[int, Box]]], dets: list[list[Detection]],
              frame_rate: float = FRAME_RATE) -> dict[str, Result]:
    """Every peer configuration on the same detections (subprocess in the peer venv), scored by `score`."""
    if not PEER_PY.exists():
        print(f"# peers skipped: {PEER_PY} missing (make mot-venv)", file=sys.stderr)
        return {}
    job = {"frame_rate": frame_rate, "configs": peer_configs(),
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

@dataclass(frozen=True)
class DevSeq:
    """One sequence of the development MOT data."""

    name: str
    video: str  # windows of one video are averaged before videos are compared
    path: Path
    fps: float


def dev_sequences() -> list[DevSeq]:
    """TUD-Campus and every built window of the mot_corpus (CORPUS; missing: TUD-Campus alone)."""
    out = [DevSeq("tud_campus", "TUD-Campus", TUD, FRAME_RATE)]
    for ini in sorted(CORPUS.glob("*/seqinfo.ini")):
        info = dict(line.split("=", 1) for line in ini.read_text().splitlines() if "=" in line)
        meta = json.loads((ini.parent / "meta.json").read_text())
        out.append(DevSeq(ini.parent.name, str(meta.get("video", ini.parent.name)), ini.parent,
                          float(info.get("frameRate", 25))))
    if len(out) == 1:
        print(f"# {CORPUS} has no built sequences (../shared/mot_corpus/README.md): TUD-Campus only",
              file=sys.stderr)
    return out


DEV_DETECTORS: dict[str, Callable[[], Detector]] = {
    "yolox": YoloxDetector, "hog": lambda: HogPeopleDetector(HogParams()), "motion": MotionDetector}


def cached_detections(seq: DevSeq, name: str, cache: Path | None) -> tuple[list[list[Detection]], float]:
    """The boxes of detector `name` on every frame of `seq` and its mean time per call (ms), from
    cache/name/seq.json when there, else run (one thread) and stored there."""
    f = cache / name / f"{seq.name}.json" if cache is not None else None
    if f is not None and f.is_file():
        d = json.loads(f.read_text())
        return [[Detection(Box(*b[:4]), b[4]) for b in fr] for fr in d["frames"]], d["ms"]
    det = DEV_DETECTORS[name]()
    frames, times = [], []
    for img, _ in tud_frames(seq.path):
        t0 = time.perf_counter()
        frames.append(det.detect(img))
        times.append(time.perf_counter() - t0)
    ms = 1000.0 * float(np.mean(times))
    if f is not None:
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text(json.dumps({"ms": ms, "frames": [[[*d.box.as_tuple(), d.score] for d in fr]
                                                       for fr in frames]}))
    return frames, ms


def detection_pr(gts: list[list[tuple[int, Box]]], dets: list[list[Detection]],
                 min_iou: float = 0.5) -> tuple[float, float, int, int]:
    """(precision, recall, detections, ground-truth boxes) at IoU >= min_iou, greedy per frame."""
    tp = nd = ng = 0
    for gt, fr in zip(gts, dets, strict=True):
        matched, _ = greedy_matches([d.box for d in fr], [b for _, b in gt], min_iou)
        tp += len(matched)
        nd += len(fr)
        ng += len(gt)
    return tp / max(nd, 1), tp / max(ng, 1), nd, ng


def video_mean(per_seq: dict[str, float], seqs: list[DevSeq]) -> float:
    """Mean over videos of the mean over each video's windows."""
    by_video: dict[str, list[float]] = {}
    for q in seqs:
        by_video.setdefault(q.video, []).append(per_seq[q.name])
    return float(np.mean([np.mean(v) for v in by_video.values()]))


def dev_detection_table(seqs: list[DevSeq], cache: Path | None, detectors: Iterable[str]) -> str:
    lines = ["### Detectors on the development MOT data: precision / recall at IoU 0.5", "",
             "| detector | " + " | ".join(q.name for q in seqs)
             + " | mean over videos (P / R) | ms per call |",
             "|---|" + "---|" * (len(seqs) + 2)]
    for name in detectors:
        cells, ps, rs, ms = [], {}, {}, []
        for q in seqs:
            gts = [gt for _, gt in tud_frames(q.path)]
            dets, t = cached_detections(q, name, cache)
            ps[q.name], rs[q.name], _, _ = detection_pr(gts, dets)
            ms.append(t)
            cells.append(f"{100 * ps[q.name]:.1f} / {100 * rs[q.name]:.1f}")
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {100 * video_mean(ps, seqs):.1f} / "
                     f"{100 * video_mean(rs, seqs):.1f} | {np.mean(ms):.0f} |")
    return "\n".join(lines) + "\n"


def learned_mot_params() -> MotParams:
    """MotParams with the mot section of params/acquisition_learned.yaml (the association decided for the
    learned detector's boxes); frame_rate is set per sequence by `dev_mot`."""
    import yaml

    doc = yaml.safe_load((REPO / "params" / "acquisition_learned.yaml").read_text())
    return replace(MotParams(), **doc["/**"]["ros__parameters"]["mot"])


def dev_mot(seqs: list[DevSeq], cache: Path | None, detector: str, variants: dict[str, MotParams],
            siamese: SiameseFamily, peers: bool = True) -> dict[str, dict[str, Result]]:
    """{row: {sequence: Result}}: each variant of our association and every peer configuration on the
    detector's own boxes."""
    out: dict[str, dict[str, Result]] = {}
    for q in seqs:
        gts = [gt for _, gt in tud_frames(q.path)]
        dets, _ = cached_detections(q, detector, cache)
        replay = Replay.of(dets)
        for name, params in variants.items():
            replay.reset()
            trk = MultiTargetTracker(replace(params, frame_rate=q.fps), siamese)
            out.setdefault(name, {})[q.name] = evaluate(tud_frames(q.path), replay, trk)
        if peers:
            for name, r in run_peers(gts, dets, q.fps).items():
                out.setdefault(name, {})[q.name] = r
        add_hota(gts, {k: v[q.name] for k, v in out.items()})
    return out


def dev_mot_table(title: str, res: dict[str, dict[str, Result]], seqs: list[DevSeq]) -> str:
    """Per sequence MOTA / IDF1 / IDSW and the mean over videos; each peer's defaults and its grid setting
    best by the mean over videos (MOTA, then IDF1) chosen on this table."""
    mean = {k: (video_mean({q: r.mota for q, r in v.items()}, seqs),
                video_mean({q: r.idf1 for q, r in v.items()}, seqs)) for k, v in res.items()}
    hota = {k: video_mean({q: r.hota for q, r in v.items()}, seqs) for k, v in res.items()}
    rows = [k for k in res if not k.startswith(("SORT", "ByteTrack", "OC-SORT"))]
    for peer in ("SORT", "ByteTrack", "OC-SORT"):
        grid = [k for k in res if k == peer or k.startswith(peer + " ")]
        if grid:
            rows.append(peer)
            best = max(grid, key=lambda k: mean[k])
            if best != peer:
                rows.append(best)
    lines = [f"### {title}", "", "MOTA / IDF1 / ID switches per sequence; MOTA, IDF1 and HOTA "
             "(`trackers.eval`, TrackEval's matching) as means over videos (windows of one video averaged "
             "first).", "",
             "| | " + " | ".join(q.name for q in seqs) + " | MOTA | IDF1 | HOTA |",
             "|---|" + "---|" * (len(seqs) + 3)]
    for k in rows:
        label = f"{k} (defaults)" if k in ("SORT", "ByteTrack", "OC-SORT") else k
        if k.startswith(("SORT ", "ByteTrack ", "OC-SORT ")):
            label = f"{k} (best of grid)"
        cells = [f"{100 * r.mota:.1f} / {100 * r.idf1:.1f} / {r.idsw}"
                 for r in (res[k][q.name] for q in seqs)]
        lines.append(f"| {label} | " + " | ".join(cells)
                     + f" | {100 * mean[k][0]:.1f} | {100 * mean[k][1]:.1f} | {100 * hota[k]:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two synthetic scenes per family instead of five")
    ap.add_argument("--no-hog", action="store_true", help="skip HOG on TUD (about 1 s per frame)")
    ap.add_argument("--det-cache", default="", help="folder caching each detector's boxes per development "
                    "sequence (dev-detection, dev-mot)")
    ap.add_argument("--dev-detectors", default="yolox,hog,motion", help="detectors of the dev tables")
    ap.add_argument("--only", default=",".join(DEFAULT_FAMILIES),
                    help=f"comma-separated tables to run (default all but dev-*): {', '.join(FAMILIES)}")
    args = ap.parse_args(argv)
    only = {f.strip() for f in args.only.split(",") if f.strip()}
    unknown = only - set(FAMILIES)
    if unknown:
        ap.error(f"unknown --only {sorted(unknown)}; choose from {', '.join(FAMILIES)}")
    if args.no_hog:
        only.discard("tud-hog")
    cache = Path(args.det_cache) if args.det_cache else None
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
    dev_dets = [d.strip() for d in args.dev_detectors.split(",") if d.strip()]
    unknown_dets = set(dev_dets) - set(DEV_DETECTORS)
    if unknown_dets:
        ap.error(f"unknown --dev-detectors {sorted(unknown_dets)}; choose from {', '.join(DEV_DETECTORS)}")
    problem = model_problem() if "yolox" in dev_dets and only & {"dev-detection", "dev-mot"} else None
    if problem is not None:
        print(f"# yolox skipped: {problem}", file=sys.stderr)
        dev_dets.remove("yolox")
    if "dev-detection" in only:
        print(dev_detection_table(dev_sequences(), cache, dev_dets))
    if "dev-mot" in only:
        seqs = dev_sequences()
        for name in dev_dets:
            rows = {"ours (defaults)": MotParams(), "ours (acquisition_learned.yaml)": learned_mot_params()}
            res = dev_mot(seqs, cache, name, rows, siamese)
            print(dev_mot_table(f"Development MOT data, the {name} detector's own boxes", res, seqs))
    print(f"total {time.time() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
