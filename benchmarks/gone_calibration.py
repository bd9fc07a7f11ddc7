# SPDX-License-Identifier: Apache-2.0
"""Fit and score the network's gone verdict (policies/gone.py) on the cue dumps of benchmarks/gone_cues.py.

Label: gone = absent in gt.txt, or IoU of the network's box with the truth < 0.1. The rule (GoneParams):
gone when the score map's PSR is below `psr_gone` or the chosen score below `score_gone`; after a gone frame,
found again only at PSR >= `psr_resume` (hysteresis). Its constants are picked from a grid on training folds
and scored on the held-out ones: 5 folds grouped by VIDEO (all sequences of a video in one fold), so that
no constant is scored on a video it was fitted on. The pick: the largest recall of gone with at most
`--max-cost` of the training frames with IoU >= 0.5 said gone, as a mean over the training videos (the OPE
cost proxy: a frame the verdict blanks loses its overlap; per video, so that a rule that blanks one whole
video is not hidden by the long ones).

Reported per rule (pooled over the held-out folds): precision and recall of gone, recall on absent frames,
false-loss rate (said gone on frames not gone: present, IoU >= 0.1), the share of IoU >= 0.5 frames said
gone, and the OPE success AUC (mean over sequences, frames 2..N, absent frames left out) of the network
alone and with the frames said gone blanked (box IoU 0). Baseline: PSR < 7 (paper 000; core/siamese/base.py
today). `--explore` adds logistic rules on 2-4 cues (a running mean of recent confident PSRs among them)
fitted the same way; `--pool` also fits one rule on all dumps together (folds still by video).

    .venv/bin/python benchmarks/gone_calibration.py out/gone/cues_v3.npz out/gone/cues_v2.npz --pool
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections import deque
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from swir_tracker_ros.harness.metrics import auc, success_curve
from swir_tracker_ros.policies.gone import CUE_NAMES, GoneCues, GoneParams, GoneVerdict

FOLDS = 5
PSR_GONE = tuple(float(v) for v in np.round(np.arange(2.5, 5.01, 0.25), 2))
PSR_RESUME = (0.0, 10.0, 15.0, 20.0, 30.0, 40.0, 60.0, 80.0, 100.0, 150.0, 200.0, 300.0)  # 0: no hysteresis
SCORE_GONE = (0.0, 0.5, 0.7, 0.85)
RESUME_RATIO = (0.0, 0.5, 0.75, 1.0, 1.5)  # 0: psr_resume alone
LOGISTIC_SETS: tuple[tuple[str, ...], ...] = (
    ("log_psr", "score"), ("log_psr", "rel_psr"), ("log_psr", "log_apce", "second"),
    ("log_psr", "score", "second", "rel_psr"), ("log_psr", "pscore", "rel_psr", "mass"),
)
LOGIT_MARGINS = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0)
HISTORY, CONFIDENT_PSR = 25, 7.0  # the running mean of recent confident PSRs (--explore's rel_psr)


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as z:
        return {k: z[k] for k in z.files if k != "version"} | {"version": np.array(str(z["version"]))}


def pool(dumps: Sequence[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Dumps stacked; sequences renamed per dump (`v3/...`) so that replays restart, videos kept."""
    out = {k: np.concatenate([d[k] for d in dumps]) for k in dumps[0] if k != "version"}
    out["sequence"] = np.concatenate([np.char.add(f"{d['version']}/", d["sequence"]) for d in dumps])
    out["version"] = np.array("+".join(str(d["version"]) for d in dumps))
    return out


def labels(d: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(gone, good): gone = absent or IoU < 0.1; good = present with IoU >= 0.5."""
    iou = d["iou"]
    return d["absent"] | (np.nan_to_num(iou, nan=1.0) < 0.1), ~d["absent"] & (np.nan_to_num(iou) >= 0.5)


def folds_by_video(videos: np.ndarray, k: int = FOLDS) -> np.ndarray:
    """Fold index per frame: videos sorted by frame count (largest first) dealt to the lightest fold."""
    names, counts = np.unique(videos, return_counts=True)
    weight, fold_of = np.zeros(k), {}
    for j in np.argsort(-counts, kind="stable"):
        f = int(np.argmin(weight))
        fold_of[names[j]] = f
        weight[f] += counts[j]
    return np.array([fold_of[v] for v in videos])


def starts(seq: np.ndarray) -> np.ndarray:
    return np.r_[True, seq[1:] != seq[:-1]]


def replay_thresholds(d: dict[str, np.ndarray], grid: np.ndarray, history: int) -> np.ndarray:
    """Flags (frames x rules) of GoneVerdict for every (psr_gone, psr_resume, score_gone, resume_ratio) row
    of `grid` at once, restarted at each sequence (GoneVerdict.judge_cues vectorised over rules)."""
    gone_bar, resume_max, ratio = grid[:, 0], np.maximum(grid[:, 1], grid[:, 0]), grid[:, 3]
    psr, score, first = d["psr"], d["score"], starts(d["sequence"])
    low = score[:, None] < grid[None, :, 2]
    log_psr = np.log(np.maximum(psr, 1e-6))
    a = 1.0 / history
    flags = np.zeros((len(psr), len(grid)), dtype=bool)
    state = np.zeros(len(grid), dtype=bool)
    typical = np.full(len(grid), np.nan)
    for i in range(len(psr)):
        if first[i]:
            state[:] = False
            typical[:] = np.nan
        relative = np.where((ratio > 0) & ~np.isnan(typical),
                            np.maximum(gone_bar, ratio * np.exp(np.nan_to_num(typical))), np.inf)
        bar = np.where(state, np.minimum(resume_max, relative), gone_bar)
        state = low[i] | (psr[i] < bar)
        typical = np.where(state, typical,
                           np.where(np.isnan(typical), log_psr[i], (1 - a) * typical + a * log_psr[i]))
        flags[i] = state
    return flags


def video_cost(flags: np.ndarray, good: np.ndarray, videos: np.ndarray) -> np.ndarray:
    """Per rule: the mean over videos of the share of a video's `good` frames said gone (each video weighs
    the same: a rule that blanks one whole video is not hidden by the long ones)."""
    names = np.unique(videos[good])
    w = np.zeros((len(names), len(videos)), dtype=np.float32)
    for i, v in enumerate(names):
        m = good & (videos == v)
        w[i, m] = 1.0 / m.sum()
    return (w @ flags.astype(np.float32)).mean(axis=0)


def choose(flags: np.ndarray, y: np.ndarray, good: np.ndarray, max_cost: float,
           videos: np.ndarray | None = None) -> int:
    """The rule (column) of largest recall whose share of `good` frames said gone is at most max_cost (ties:
    the cheaper, then the first); with `videos`, that share is the mean over videos (`video_cost`)."""
    cost = flags[good].mean(axis=0) if videos is None else video_cost(flags, good, videos)
    recall = np.where(cost <= max_cost, flags[y].mean(axis=0), -1.0)
    return int(np.argmax(recall - 1e-6 * cost))


def cross_validate(d: dict[str, np.ndarray], flags: np.ndarray, max_cost: float,
                   by_video: bool = True) -> tuple[np.ndarray, list[int]]:
    """Held-out flags of the rule picked (`choose`) on the other folds, and the pick of each fold. A
    sequence lies in one fold, so the replay over all frames is the replay over the held-out ones."""
    y, good = labels(d)
    fold = folds_by_video(d["video"])
    out, picks = np.zeros(len(y), dtype=bool), []
    for k in range(FOLDS):
        tr, te = fold != k, fold == k
        j = choose(flags[tr], y[tr], good[tr], max_cost, d["video"][tr] if by_video else None)
        out[te] = flags[te, j]
        picks.append(j)
    return out, picks


def scores(flag: np.ndarray, d: dict[str, np.ndarray]) -> dict[str, float]:
    y, good = labels(d)
    absent, iou, seqs = d["absent"], d["iou"], d["sequence"]
    aucs = []
    for s in np.unique(seqs):
        m = (seqs == s) & ~absent
        aucs.append((auc(success_curve(iou[m])), auc(success_curve(np.where(flag[m], 0.0, iou[m])))))
    a = np.array(aucs)
    return {"precision": float(flag[y].sum() / max(flag.sum(), 1)), "recall": float(flag[y].mean()),
            "absent_recall": float(flag[absent].mean()) if absent.any() else math.nan,
            "false_loss": float(flag[~y].mean()), "cost_iou50": float(flag[good].mean()),
            "ope": float(a[:, 0].mean()), "ope_verdict": float(a[:, 1].mean())}


def verdict_flags(d: dict[str, np.ndarray], p: GoneParams) -> np.ndarray:
    """GoneVerdict.judge_cues itself replayed over the dump, reset at each sequence."""
    out = np.zeros(len(d["frame"]), dtype=bool)
    v, first = GoneVerdict(p), starts(d["sequence"])
    for i in range(len(out)):
        if first[i]:
            v.reset()
        out[i] = v.judge_cues(GoneCues(**{k: float(d[k][i]) for k in CUE_NAMES}))
    return out


def params_of(g: Sequence[float], history: int) -> GoneParams:
    return GoneParams(psr_gone=float(g[0]), psr_resume=float(max(g[1], g[0])), score_gone=float(g[2]),
                      resume_ratio=float(g[3]), history=history)


# --- --explore: logistic rules on a few cues ------------------------------------------------------------

def feature_table(d: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Candidate features per frame; rel_psr = log(PSR / mean PSR of the last HISTORY frames with PSR >=
    CONFIDENT_PSR), 0 before the first such frame (online, per sequence)."""
    rows = []
    first = starts(d["sequence"])
    recent: deque[float] = deque(maxlen=HISTORY)
    for i in range(len(d["frame"])):
        if first[i]:
            recent.clear()
        c = {k: float(d[k][i]) for k in CUE_NAMES}
        lp = math.log(max(c["psr"], 0.1))
        rel = lp - math.log(max(sum(recent) / len(recent), 0.1)) if recent else 0.0
        rows.append((lp, c["score"], c["pscore"], math.log(max(c["apce"], 0.1)), c["second"], c["mass"], rel))
        if c["psr"] >= CONFIDENT_PSR:
            recent.append(c["psr"])
    names = ("log_psr", "score", "pscore", "log_apce", "second", "mass", "rel_psr")
    return dict(zip(names, np.array(rows).T))


def fit_logistic(x: np.ndarray, y: np.ndarray, l2: float = 1e-3, iters: int = 50) -> np.ndarray:
    """Weights (bias first) of a logistic regression by Newton steps on standardised features, returned for
    the raw features; L2 on the standardised weights (not the bias)."""
    mu, sd = x.mean(axis=0), x.std(axis=0) + 1e-12
    xs = np.hstack([np.ones((len(x), 1)), (x - mu) / sd])
    w = np.zeros(xs.shape[1])
    reg = l2 * len(x) * np.eye(xs.shape[1])
    reg[0, 0] = 0.0
    for _ in range(iters):
        p = 1.0 / (1.0 + np.exp(-np.clip(xs @ w, -30, 30)))
        step = np.linalg.solve((xs * (p * (1 - p))[:, None]).T @ xs + reg + 1e-9 * np.eye(len(w)),
                               xs.T @ (p - y) + reg @ w)
        w -= step
        if np.max(np.abs(step)) < 1e-8:
            break
    raw = w[1:] / sd
    return np.concatenate([[w[0] - float(raw @ mu)], raw])


def replay_logit(z: np.ndarray, first: np.ndarray, gone: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """Flags of "gone when z > gone, or after a gone frame while z > gone - margin" for each pair."""
    flags = np.zeros((len(z), len(gone)), dtype=bool)
    state = np.zeros(len(gone), dtype=bool)
    for i in range(len(z)):
        if first[i]:
            state[:] = False
        state = z[i] > np.where(state, gone - margin, gone)
        flags[i] = state
    return flags


def cross_validate_logistic(d: dict[str, np.ndarray], f: dict[str, np.ndarray], names: Sequence[str],
                            max_cost: float) -> np.ndarray:
    y, good = labels(d)
    fold, first = folds_by_video(d["video"]), starts(d["sequence"])
    x = np.column_stack([f[n] for n in names])
    out = np.zeros(len(y), dtype=bool)
    for k in range(FOLDS):
        tr, te = fold != k, fold == k
        w = fit_logistic(x[tr], y[tr].astype(float))
        z = w[0] + x @ w[1:]
        qs = np.unique(np.quantile(z[tr], np.linspace(0.5, 0.999, 100)))
        gone = np.repeat(qs, len(LOGIT_MARGINS))
        margin = np.tile(np.asarray(LOGIT_MARGINS), len(qs))
        flags = replay_logit(z, first, gone, margin)
        j = choose(flags[tr], y[tr], good[tr], max_cost, d["video"][tr])
        out[te] = flags[te, j]
    return out


# --- report -----------------------------------------------------------------------------------------------

HEADER = ("| rule | precision | recall | absent recall | false-loss | IoU>=0.5 said gone | OPE network | "
          "OPE with verdict |\n|---|---|---|---|---|---|---|---|")


def row(name: str, s: dict[str, float]) -> str:
    return (f"| {name} | {s['precision']:.3f} | {s['recall']:.3f} | {s['absent_recall']:.3f} | "
            f"{s['false_loss']:.4f} | {s['cost_iou50']:.4f} | {s['ope']:.3f} | {s['ope_verdict']:.3f} |")


def describe(g: Sequence[float]) -> str:
    resume = "none" if g[1] <= g[0] else f"min({g[1]:g}, {g[3]:g} x typical)" if g[3] > 0 else f"{g[1]:g}"
    return f"PSR<{g[0]:g}, resume PSR>={resume}, score<{g[2]:g}"


def report(d: dict[str, np.ndarray], costs: Sequence[float], explore: bool, ship: GoneParams) -> None:
    y, good = labels(d)
    grid = np.array(list(itertools.product(PSR_GONE, PSR_RESUME, SCORE_GONE, RESUME_RATIO)))
    flags = replay_thresholds(d, grid, ship.history)
    no_hyst = (grid[:, 1] <= grid[:, 0]) & (grid[:, 2] == 0.0) & (grid[:, 3] == 0.0)
    fixed = grid[:, 3] == 0.0
    print(f"\n## {d['version']}: {len(y)} frames, {len(np.unique(d['sequence']))} sequences, "
          f"{len(np.unique(d['video']))} videos; gone {int(y.sum())} (absent {int(d['absent'].sum())}), "
          f"IoU>=0.5 {int(good.sum())}\n")
    print(HEADER)
    paper = GoneParams(psr_gone=7.0, psr_resume=7.0, score_gone=0.0, resume_ratio=0.0)
    print(row("PSR < 7 (paper 000, stateless)", scores(verdict_flags(d, paper), d)))
    for cost in costs:
        held, picks = cross_validate(d, flags, cost)
        print(row(f"CV, max cost {cost}: PSR bars, hysteresis (relative), score floor", scores(held, d)))
        print("  fold picks: " + "; ".join(describe(grid[j]) for j in picks))
        for name, mask in (("fixed resume bar", fixed), ("one PSR bar (no hysteresis)", no_hyst)):
            sub = np.flatnonzero(mask)
            held, picks = cross_validate(d, flags[:, sub], cost)
            print(row(f"CV, max cost {cost}: {name}", scores(held, d)))
            print("  fold picks: " + "; ".join(describe(grid[sub[j]]) for j in picks))
    if explore:
        f = feature_table(d)
        for names in LOGISTIC_SETS:
            held = cross_validate_logistic(d, f, names, costs[0])
            print(row(f"CV logistic {'+'.join(names)}, max cost {costs[0]}", scores(held, d)))
    j = choose(flags, y, good, costs[0], d["video"])
    fit = params_of(grid[j], ship.history)
    check = verdict_flags(d, fit)
    assert np.array_equal(check, flags[:, j]), "vectorised replay differs from GoneVerdict"
    print(row(f"all data, max cost {costs[0]} (in-sample): {describe(grid[j])}", scores(check, d)))
    shipped = describe((ship.psr_gone, ship.psr_resume, ship.score_gone, ship.resume_ratio))
    print(row(f"shipped GoneParams (in-sample): {shipped}", scores(verdict_flags(d, ship), d)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dumps", nargs="+", type=Path)
    ap.add_argument("--max-cost", type=float, nargs="+", default=[0.005, 0.01, 0.02],
                    help="allowed share of IoU>=0.5 training frames said gone (the first one is the pick)")
    ap.add_argument("--pool", action="store_true", help="also fit one rule on all dumps together")
    ap.add_argument("--explore", action="store_true", help="also score logistic rules on 2-4 cues")
    args = ap.parse_args(argv)
    dumps = [load(p) for p in args.dumps]
    for d in dumps + ([pool(dumps)] if args.pool and len(dumps) > 1 else []):
        report(d, args.max_cost, args.explore, GoneParams())
    return 0


if __name__ == "__main__":
    sys.exit(main())
