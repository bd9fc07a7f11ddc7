# SPDX-License-Identifier: Apache-2.0
"""Calibrate the second opinion's judge (policies/second.py) on the development set, cross-validated over
videos.

Two stages:

1. `dump`: each network alone (`SiameseTracker`, the leader's and the second's versions) plays every sequence
   of the development set (harness/devset.py) independently, and every frame's box and search cues
   (policies/gone.py `cues`) go into one .npz per sequence (out/judge/<set>/, not committed).
2. `fit`: the judge's features (`judge_features`) on every frame where the two answers differ in their
   overlap with the ground truth by more than `--min-gap` IoU; label: the second's box overlaps more;
   weight: the difference. The prediction of the motion features is a constant-velocity one from the two
   previous frames' better box (the Kalman prediction's role online), their unit the better box's size, at
   least 32 px (LeadParams.gate_size). A logistic model (L2, features standardised) is fitted on the videos
   of k-1 folds and judged on the held-out fold: per frame the judged box is the second's when P > 0.5,
   without feedback between the two runs (online, the loser is moved onto the winner's box). Printed: the
   success AUC (present frames, 21 thresholds) of each network alone, of the per-frame oracle and of the
   judged pick, paired over videos against the second alone; then the weights fitted on all videos, in the raw
   features' units, as `SecondParams.weights` takes them.

    .venv/bin/python benchmarks/judge_calibration.py dump [--only SEQ ...]
    .venv/bin/python benchmarks/judge_calibration.py fit [--folds 5]
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.harness import metrics
from swir_tracker_ros.harness.devset import catalogue, data_dirs, sequence_folders, video_of
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.policies.gone import CUE_NAMES, GoneCues, cues
from swir_tracker_ros.policies.second import HISTORY, JUDGE_FEATURES, blend, judge_features
from swir_tracker_ros.types import Box

OUT = Path(__file__).resolve().parent.parent / "out" / "judge"


# --- 1. dump ------------------------------------------------------------------------------------------

def dump_sequence(folder: Path, versions: tuple[str, str], out: Path) -> None:
    """Play each network alone over one sequence; store every frame's box and cues (nan before the start)."""
    src = open_source(folder)
    depth = src.bits if src.bits not in (None, 8, 16) else None
    nets = {v: SiameseTracker(SiameseParams(version=v)) for v in versions}
    gts: list[list[float]] = []
    boxes: dict[str, list[list[float]]] = {v: [] for v in versions}
    cue: dict[str, list[list[float]]] = {v: [] for v in versions}
    none = [np.nan] * len(CUE_NAMES)
    started = False
    for fr in src.frames():
        gts.append([np.nan] * 4 if fr.gt is None else [fr.gt.x, fr.gt.y, fr.gt.w, fr.gt.h])
        for v, net in nets.items():
            if not started and fr.gt is None:
                boxes[v].append([np.nan] * 4)
                cue[v].append(none)
            elif not started:
                net.init(fr.image, fr.gt, bit_depth=depth)
                boxes[v].append([fr.gt.x, fr.gt.y, fr.gt.w, fr.gt.h])
                cue[v].append(none)
            else:
                res = net.update(fr.image, bit_depth=depth)
                boxes[v].append([res.box.x, res.box.y, res.box.w, res.box.h])
                c = cues(res.detection)
                cue[v].append([getattr(c, k) for k in CUE_NAMES])
        started = started or fr.gt is not None
    arrays = {"gt": np.array(gts, float), "versions": np.array(versions), "cue_names": np.array(CUE_NAMES)}
    for k, v in enumerate(versions):
        arrays[f"box{k}"] = np.array(boxes[v], float)
        arrays[f"cue{k}"] = np.array(cue[v], float)
    np.savez_compressed(out / f"{folder.name}.npz", **arrays)


# --- 2. fit -------------------------------------------------------------------------------------------

def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise IoU of (x, y, w, h) arrays; pure."""
    iw = np.clip(np.minimum(a[:, 0] + a[:, 2], b[:, 0] + b[:, 2]) - np.maximum(a[:, 0], b[:, 0]), 0, None)
    ih = np.clip(np.minimum(a[:, 1] + a[:, 3], b[:, 1] + b[:, 3]) - np.maximum(a[:, 1], b[:, 1]), 0, None)
    inter = iw * ih
    union = a[:, 2] * a[:, 3] + b[:, 2] * b[:, 3] - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-9), 0.0)


def auc(overlaps: np.ndarray) -> float:
    """Success AUC of the present frames' overlaps, as the harness scores it (harness/metrics.py)."""
    return metrics.auc(metrics.success_curve(overlaps))


def _cues(row: np.ndarray, names: list[str]) -> GoneCues:
    return GoneCues(**{k: float(row[names.index(k)]) for k in CUE_NAMES})


def typical_psr(psr: np.ndarray) -> np.ndarray:
    """Per frame, the median log1p PSR of the `HISTORY` frames before it (positive PSRs; nan: none yet), as
    `SecondOpinion` keeps it when it looks on every frame."""
    out = np.full(len(psr), np.nan)
    seen: list[float] = []
    for t, v in enumerate(psr):
        if seen:
            out[t] = float(np.median(seen[-HISTORY:]))
        if np.isfinite(v) and v > 0.0:
            seen.append(float(np.log1p(v)))
    return out


def load(root: Path) -> dict[str, dict]:
    """The dumps of `root`, each with its opinions' typical PSRs (`typical0`, `typical1`)."""
    data = {}
    for f in sorted(root.glob("*.npz")):
        z = dict(np.load(f))
        col = [str(n) for n in z["cue_names"]].index("psr")
        for k in (0, 1):
            z[f"typical{k}"] = typical_psr(z[f"cue{k}"][:, col])
        data[f.stem] = z
    return data


def features(z: dict, prev: np.ndarray, prev2: np.ndarray, t: int) -> np.ndarray:
    """The judge's features at frame t, the prediction made from the boxes `prev` (t-1) and `prev2` (t-2)."""
    names = [str(n) for n in z["cue_names"]]
    a, b = z["box0"][t], z["box1"][t]
    pcx, pcy = prev[0] + prev[2] / 2, prev[1] + prev[3] / 2
    qcx, qcy = prev2[0] + prev2[2] / 2, prev2[1] + prev2[3] / 2
    px, py = 2 * pcx - qcx, 2 * pcy - qcy
    size = max(float(np.sqrt(max(prev[2] * prev[3], 0.0))), 32.0)

    def off(x: np.ndarray) -> float:
        return float(np.hypot(x[0] + x[2] / 2 - px, x[1] + x[3] / 2 - py)) / size

    typical = tuple(None if np.isnan(z[f"typical{k}"][t]) else float(z[f"typical{k}"][t]) for k in (0, 1))
    return judge_features(_cues(z["cue0"][t], names), _cues(z["cue1"][t], names),
                          float(iou(a[None], b[None])[0]), off(a), off(b), typical)  # type: ignore[arg-type]


def frames_of(z: dict) -> np.ndarray:
    """Indices of the frames after the start with ground truth (the scored frames)."""
    has = ~np.isnan(z["cue0"][:, 0]) & ~np.isnan(z["gt"][:, 0])
    return np.flatnonzero(has)


def training_rows(z: dict, min_gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    gt = np.nan_to_num(z["gt"])
    i0, i1 = iou(z["box0"], gt), iou(z["box1"], gt)
    best = np.where((i1 >= i0)[:, None], z["box1"], z["box0"])
    rows, ys, ws = [], [], []
    for t in frames_of(z):
        d = i1[t] - i0[t]
        if abs(d) <= min_gap or t < 2:
            continue
        rows.append(features(z, best[t - 1], best[t - 2], t))
        ys.append(float(d > 0))
        ws.append(abs(d))
    n = len(JUDGE_FEATURES)
    return (np.array(rows).reshape(-1, n), np.array(ys), np.array(ws))


def fit_logistic(x: np.ndarray, y: np.ndarray, w: np.ndarray, l2: float) -> np.ndarray:
    """Weighted L2 logistic regression on standardised features; the weights in raw units, bias last."""
    mu, sd = x.mean(0), x.std(0) + 1e-9
    xs = np.hstack([(x - mu) / sd, np.ones((len(x), 1))])

    def loss(beta: np.ndarray) -> tuple[float, np.ndarray]:
        s = xs @ beta
        p = 1.0 / (1.0 + np.exp(-s))
        val = float(np.sum(w * (np.logaddexp(0.0, s) - y * s)) / w.sum() + l2 * beta[:-1] @ beta[:-1])
        g = xs.T @ (w * (p - y)) / w.sum()
        g[:-1] += 2 * l2 * beta[:-1]
        return val, g

    beta = minimize(loss, np.zeros(xs.shape[1]), jac=True, method="L-BFGS-B").x
    raw = beta[:-1] / sd
    return np.append(raw, beta[-1] - float(raw @ mu))


def judged(z: dict, weights: np.ndarray, share: float = 0.0, agree: float = 0.5) -> np.ndarray:
    """The judged box per frame (no feedback): the second's where P > 0.5, the prediction from the judged
    boxes themselves (as online); where the two agree (IoU >= `agree`), `share` of the second's box blended
    into the standing one (`policies.second.blend`)."""
    out = z["box0"].copy()
    for t in frames_of(z):
        if t < 2:
            continue
        f = features(z, out[t - 1], out[t - 2], t)
        p = 1.0 / (1.0 + np.exp(-(weights[:-1] @ f + weights[-1])))
        a, b = z["box0"][t], z["box1"][t]
        out[t] = b if p > 0.5 else a
        if share > 0.0 and iou(a[None], b[None])[0] >= agree:
            mixed = blend(Box(*out[t]), Box(*b), share)
            out[t] = [mixed.x, mixed.y, mixed.w, mixed.h]
    return out


def fit(root: Path, folds: int, min_gap: float, l2: float, share: float) -> None:
    data = load(root)
    if not data:
        raise SystemExit(f"judge_calibration: no dumps under {root}: run the dump stage first")
    infos = catalogue(data_dirs(None))
    vid = {n: video_of(n, infos) for n in data}
    videos = sorted(set(vid.values()))
    order = np.random.default_rng(0).permutation(len(videos))
    fold = {videos[i]: k % folds for k, i in enumerate(order)}
    rows = {n: training_rows(z, min_gap) for n, z in data.items()}
    scores: dict[str, list[float]] = {}
    for k in range(folds):
        train = [rows[n] for n in data if fold[vid[n]] != k]
        w = fit_logistic(np.vstack([r[0] for r in train]), np.concatenate([r[1] for r in train]),
                         np.concatenate([r[2] for r in train]), l2)
        for n, z in data.items():
            if fold[vid[n]] != k:
                continue
            t = frames_of(z)
            gt = z["gt"][t]
            i0, i1 = iou(z["box0"][t], gt), iou(z["box1"][t], gt)
            scores[n] = [auc(i0), auc(i1), auc(np.maximum(i0, i1)), auc(iou(judged(z, w, share)[t], gt))]
    per: dict[str, list[list[float]]] = {}
    for n, s in scores.items():
        per.setdefault(vid[n], []).append(s)
    v = np.array([np.mean(s, axis=0) for s in per.values()])
    versions = [str(x) for x in next(iter(data.values()))["versions"]]
    print(f"{len(scores)} sequences, {len(v)} videos, {folds} folds over videos")
    for j, name in enumerate((f"{versions[0]} alone", f"{versions[1]} alone", "per-frame oracle",
                              "judged (held-out fold)")):
        d = v[:, j] - v[:, 1]
        se = d.std(ddof=1) / np.sqrt(len(d))
        print(f"  {name:24s} {v[:, j].mean():.4f}   vs {versions[1]} alone {d.mean():+.4f} SE {se:.4f} "
              f"wins/losses {int((d > 0.005).sum())}/{int((d < -0.005).sum())}")
    every = list(rows.values())
    allw = fit_logistic(np.vstack([r[0] for r in every]), np.concatenate([r[1] for r in every]),
                        np.concatenate([r[2] for r in every]), l2)
    print("weights on all videos (SecondParams.weights):")
    print("  [" + ", ".join(f"{x:.4f}" for x in allw) + "]")
    for name, x in zip((*JUDGE_FEATURES, "bias"), allw):
        print(f"  {name:20s} {x:+.4f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stage", choices=("dump", "fit"))
    ap.add_argument("--versions", nargs=2, default=("v3", "lighttrack"), metavar=("LEADER", "SECOND"))
    ap.add_argument("--data", nargs="+", default=None, help="data folders (default: the development set)")
    ap.add_argument("--out", default=None, help=f"dump folder (default: {OUT}/<leader>_<second>)")
    ap.add_argument("--only", nargs="+", default=None, help="only these sequences (dump)")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--min-gap", type=float, default=0.1, help="IoU gap of a training frame")
    ap.add_argument("--l2", type=float, default=1e-2)
    ap.add_argument("--blend", type=float, default=0.0, help="SecondParams.blend of the judged pick")
    a = ap.parse_args(argv)
    root = Path(a.out) if a.out else OUT / "_".join(a.versions)
    if a.stage == "fit":
        fit(root, a.folds, a.min_gap, a.l2, a.blend)
        return 0
    root.mkdir(parents=True, exist_ok=True)
    for name, folder in sorted(sequence_folders(data_dirs(a.data)).items()):
        if (a.only and name not in a.only) or (root / f"{name}.npz").exists():
            continue
        t0 = time.perf_counter()
        dump_sequence(folder, tuple(a.versions), root)
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
