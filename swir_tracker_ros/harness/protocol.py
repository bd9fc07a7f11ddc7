# SPDX-License-Identifier: Apache-2.0
"""The evaluation protocol of issue 12: OPE and SRE for our variants and OpenCV peers on the same frames.

OPE: one run per sequence from the ground-truth box of the first frame with ground truth. SRE (Wu et al.,
CVPR 2013): 12 more runs from perturbed start boxes (`metrics.sre_box`). Every run is scored on the frames
AFTER its start frame (frames 2..N), with the same metrics for every tracker, plus "false tracking" (state
`tracking`, or OpenCV's ok, while IoU = 0) and, on synthetic scenarios, the share of occlusions survived.
One command (`harness compare ... --protocol ope sre`) prints and writes all of it (docs/harness.md).
"""

from __future__ import annotations

import math
import subprocess
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.evaluate import Run, make_tracker_factory, run_starts
from swir_tracker_ros.harness.metrics import (
    SRE_PERTURBATIONS,
    auc,
    carried_truth,
    false_tracking,
    occlusion_episodes,
    occlusions_survived,
    overlaps,
    score,
    success_curve,
    zero_overlap,
)
from swir_tracker_ros.harness.sources import Source

PROTOCOLS = ("ope", "sre")
PEER_PREFIX = "opencv_"
REPO = Path(__file__).resolve().parents[2]
_COST = {"CSRT": 0, "ours": 1, "KCF": 2, "MOSSE": 3}  # slowest peers first (better packing on --jobs)


@dataclass
class RunStats:
    """Scores of one run (one tracker, one sequence, one start), frames after the start frame."""

    success_auc: float
    precision_20: float
    false_tracking: int  # state tracking (OpenCV: ok) with IoU 0
    zero_iou: int  # frames with IoU 0 or no box, whatever the state
    frames: int  # scored frames
    fps: float  # frames / tracker seconds
    occlusions: int = 0  # occlusion episodes after the start (synthetic sources)
    survived: int = 0  # of those, re-acquired within metrics.RECOVERY_S
    carried_auc: float | None = None  # AUC against the truth carried by the start box (metrics.carried_truth)
    floor_auc: float | None = None  # AUC of the carried truth itself: exact tracking of the start's box

    @classmethod
    def of(cls, run: Run, fps: float) -> RunStats:
        gt = [g if k > run.init_index else None for k, g in enumerate(run.gt)]
        s = score(run.pred, gt, run.seconds)
        episodes: list[tuple[int, int]] = []
        if any(o is not None for o in run.occlusion):
            episodes = [e for e in occlusion_episodes(run.occlusion, fps) if e[0] > run.init_index]
        carried = floor = None
        ref = run.gt[run.init_index] if run.init is not None and run.init_index < len(run.gt) else None
        if ref is not None:
            truth = carried_truth(run.init, ref, gt)
            carried = auc(success_curve(overlaps(run.pred, truth)))
            floor = auc(success_curve(overlaps(truth, gt)))
        return cls(s.success_auc, s.precision_20, false_tracking(run.states, run.pred, gt),
                   zero_overlap(run.pred, gt), s.frames, s.fps, len(episodes),
                   occlusions_survived(episodes, run.states, run.pred, gt, fps), carried, floor)


@dataclass(frozen=True)
class Task:
    """One tracker on one source from several starts (run side by side in one process)."""

    label: str  # our variant name, or opencv_<tracker>
    source: Source
    starts: tuple[str, ...]
    style: str = "otb"
    pipeline: str | None = None
    overrides: tuple[str, ...] = ()
    peer: str | None = None  # OpenCV tracker name for peers
    cache_root: str | None = None
    bench_py: str | None = None
    opencv: str | None = None

    @property
    def order(self) -> tuple[bool, bool, int]:
        """Real sequences first; ours before the peers (usually cached); slow peers first (packing)."""
        return (self.source.kind == "synth", self.peer is not None, _COST.get(self.peer or "ours", 1))


@dataclass
class TaskResult:
    label: str
    sequence: str
    kind: str
    stats: dict[str, RunStats]
    computed: int  # runs actually computed (peers: not loaded from the cache)
    seconds: float  # wall time of the task


def execute(task: Task) -> TaskResult:
    """Run one task (in a pool worker or inline)."""
    t0 = time.perf_counter()
    if task.peer is None:
        factory = make_tracker_factory(task.label, task.pipeline, task.overrides)
        runs = run_starts(task.source, factory, task.starts, task.style)
        computed = len(runs)
    else:
        from swir_tracker_ros.harness.compare import PeerCache, peer_runs

        runs, computed = peer_runs(task.source, task.peer, task.starts, task.style,
                                   PeerCache(task.cache_root), Path(task.bench_py), task.opencv)
    stats = {k: RunStats.of(r, task.source.fps) for k, r in runs.items()}
    return TaskResult(task.label, task.source.name, task.source.kind, stats, computed,
                      time.perf_counter() - t0)


@dataclass
class ProtocolResult:
    """stats[sequence][tracker][start] for start in ("none", *SRE_PERTURBATIONS) as run."""

    protocols: tuple[str, ...]
    stats: dict[str, dict[str, dict[str, RunStats]]] = field(default_factory=dict)
    kinds: dict[str, str] = field(default_factory=dict)  # sequence -> "real" or "synth"
    trackers: list[str] = field(default_factory=list)
    meta: dict = field(default_factory=dict)

    def groups(self) -> dict[str, list[str]]:
        out: dict[str, list[str]] = {}
        for seq, kind in self.kinds.items():
            out.setdefault(kind, []).append(seq)
        return out

    def sre(self, seq: str, tracker: str) -> dict[str, float] | None:
        runs = self.stats.get(seq, {}).get(tracker, {})
        aucs = [runs[p].success_auc for p in SRE_PERTURBATIONS if p in runs]
        if not aucs:
            return None
        out = {"mean": float(np.mean(aucs)), "min": float(np.min(aucs)), "max": float(np.max(aucs)),
               "spread": float(np.max(aucs) - np.min(aucs)), "runs": len(aucs),
               "precision_20": float(np.mean([runs[p].precision_20 for p in SRE_PERTURBATIONS
                                              if p in runs]))}
        for key in ("carried_auc", "floor_auc"):  # absent in JSON written before they existed
            vals = [getattr(runs[p], key) for p in SRE_PERTURBATIONS if p in runs]
            if vals and all(v is not None for v in vals):
                name = key.removesuffix("_auc")
                out[f"{name}_mean"] = float(np.mean(vals))
                out[f"{name}_spread"] = float(np.max(vals) - np.min(vals))
        return out

    def summary(self, tracker: str, seqs: Sequence[str]) -> dict:
        """Means over `seqs` (each sequence weighs the same) and sums of frame counts."""
        ope = [self.stats[s][tracker]["none"] for s in seqs if "none" in self.stats[s].get(tracker, {})]
        sre = [v for v in (self.sre(s, tracker) for s in seqs) if v is not None]
        sre_runs = [r for s in seqs for p, r in self.stats[s].get(tracker, {}).items() if p != "none"]
        out: dict = {"sequences": len(seqs)}
        if ope:
            out.update(ope_auc=float(np.mean([r.success_auc for r in ope])),
                       ope_precision_20=float(np.mean([r.precision_20 for r in ope])),
                       ope_false_tracking=int(sum(r.false_tracking for r in ope)),
                       ope_zero_iou=int(sum(r.zero_iou for r in ope)),
                       ope_occlusions=int(sum(r.occlusions for r in ope)),
                       ope_survived=int(sum(r.survived for r in ope)),
                       fps=float(np.mean([r.fps for r in ope])))
        if sre:
            out.update(sre_auc=float(np.mean([v["mean"] for v in sre])),
                       sre_precision_20=float(np.mean([v["precision_20"] for v in sre])),
                       sre_spread=float(np.mean([v["spread"] for v in sre])),
                       **{f"sre_{name}_{stat}": float(np.mean([v[f"{name}_{stat}"] for v in sre]))
                          for name in ("carried", "floor") for stat in ("mean", "spread")
                          if all(f"{name}_{stat}" in v for v in sre)},
                       sre_false_tracking=int(sum(r.false_tracking for r in sre_runs)),
                       sre_zero_iou=int(sum(r.zero_iou for r in sre_runs)),
                       sre_occlusions=int(sum(r.occlusions for r in sre_runs)),
                       sre_survived=int(sum(r.survived for r in sre_runs)),
                       sre_runs=len(sre_runs))
        return out

    @classmethod
    def from_json(cls, data: dict) -> ProtocolResult:
        """Inverse of `to_json` (for --reuse and re-printing)."""
        out = cls(tuple(data["protocols"]), trackers=list(data["trackers"]), meta=dict(data.get("meta", {})))
        for seq, row in data["sequences"].items():
            out.kinds[seq] = row["kind"]
            out.stats[seq] = {}
            for t in out.trackers:
                runs = {} if row.get(t) is None else dict(row[t].get("sre") or {})
                if row.get(t) and row[t].get("ope"):
                    runs["none"] = row[t]["ope"]
                out.stats[seq][t] = {k: RunStats(**v) for k, v in runs.items()}
        return out

    def to_json(self) -> dict:
        seqs = {}
        for seq, per in self.stats.items():
            row: dict = {"kind": self.kinds[seq]}
            for t, runs in per.items():
                row[t] = {"ope": asdict(runs["none"]) if "none" in runs else None,
                          "sre": {p: asdict(r) for p, r in runs.items() if p != "none"},
                          "sre_summary": self.sre(seq, t)}
            seqs[seq] = row
        return {"protocols": list(self.protocols), "meta": self.meta, "trackers": self.trackers,
                "summary": {g: {t: self.summary(t, s) for t in self.trackers}
                            for g, s in self.groups().items()},
                "sequences": seqs}


def git_commit() -> str:
    """Short commit of the repository, `+dirty` when tracked files differ from it."""
    try:
        rev = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(REPO), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return rev + ("+dirty" if dirty else "")


def run_protocol(sources: Sequence[Source], variants: Sequence[str], peers: Sequence[str],
                 protocols: Sequence[str] = PROTOCOLS, pipeline: str | None = None, style: str = "otb",
                 jobs: int = 1, cache_root: str | Path | None = None,
                 progress: Callable[[str], None] | None = None, reuse: ProtocolResult | None = None,
                 checkpoint: Callable[[ProtocolResult], None] | None = None,
                 overrides: Sequence[str] = ()) -> ProtocolResult:
    """Every tracker (our `variants`, OpenCV `peers`) on every source from every start of `protocols`.

    `jobs` > 1 runs the (tracker, source) tasks in a process pool of that size; peer runs are read from and
    written to the cache at `cache_root` (None: no cache). A (sequence, tracker) whose every start is in
    `reuse` (an earlier result, `ProtocolResult.from_json`) is taken from there, not run. `checkpoint` is
    called with the partial result after every finished task (the CLI rewrites its --json there).
    """
    bad = [p for p in protocols if p not in PROTOCOLS]
    if bad or not protocols:
        raise HarnessError(f"unknown protocol {bad}; choose from {', '.join(PROTOCOLS)}")
    names = [s.name for s in sources]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise HarnessError(f"two sources are both called {dup[0]!r}")
    if jobs < 1:
        raise HarnessError(f"--jobs must be at least 1, got {jobs}")
    starts = (("none",) if "ope" in protocols else ()) + (SRE_PERTURBATIONS if "sre" in protocols else ())
    for v in variants:  # fail early on a bad variant / pipeline / override
        make_tracker_factory(v, pipeline, overrides)
    tasks = [Task(v, src, starts, style, pipeline, tuple(overrides)) for src in sources for v in variants]
    result = ProtocolResult(tuple(protocols), trackers=list(variants))
    meta = {"commit": git_commit(), "style": style, "pipeline": pipeline or "default",
            "overrides": list(overrides), "jobs": jobs,
            "scored": "frames after the start frame", "peer_cache": str(cache_root) if cache_root else None}
    if peers:
        from swir_tracker_ros.harness.compare import bench_python, opencv_version

        py = bench_python()
        meta["opencv"] = opencv_version(py)
        for p in peers:
            label = PEER_PREFIX + p.lower()
            result.trackers.append(label)
            root = None if cache_root is None else str(cache_root)
            tasks += [Task(label, src, starts, style, None, (), p, root, str(py), meta["opencv"])
                      for src in sources]
    result.meta = meta
    for src in sources:
        result.stats[src.name] = {t: {} for t in result.trackers}
        synth = src.kind == "synth" or src.meta.get("kind") == "synth"  # also a bag of `harness synth`
        result.kinds[src.name] = "synth" if synth else "real"
    if reuse is not None:
        kept = []
        for t in tasks:
            old = reuse.stats.get(t.source.name, {}).get(t.label, {})
            if all(k in old for k in t.starts):
                result.stats[t.source.name][t.label] = {k: old[k] for k in t.starts}
            else:
                kept.append(t)
        if progress and len(kept) < len(tasks):
            progress(f"{len(tasks) - len(kept)} (sequence, tracker) results reused")
        tasks = kept
    tasks.sort(key=lambda t: t.order)

    def take(r: TaskResult) -> None:
        result.stats[r.sequence][r.label] = r.stats
        if progress:
            ope = r.stats.get("none")
            aucs = [s.success_auc for p, s in r.stats.items() if p != "none"]
            msg = f"{r.sequence:<28} {r.label:<18}"
            if ope:
                msg += f" OPE AUC {ope.success_auc:.3f} FT {ope.false_tracking:4d}"
            if aucs:
                msg += f"  SRE AUC {np.mean(aucs):.3f} [{min(aucs):.3f}, {max(aucs):.3f}]"
            progress(msg + f"  ({r.computed} runs computed, {r.seconds:.0f} s)")
        if checkpoint:
            checkpoint(result)

    if jobs == 1:
        for t in tasks:
            take(execute(t))
    else:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
            futures = [pool.submit(execute, t) for t in tasks]
            for fut in as_completed(futures):
                take(fut.result())
    return result


def _f(v: float | None, fmt: str = ".3f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


# (label, summary key, format) of the summary rows, in print order
_MEAN_ROWS = (("OPE mean AUC", "ope_auc", ".3f"), ("OPE mean P@20", "ope_precision_20", ".3f"),
              ("OPE false tracking frames", "ope_false_tracking", "d"),
              ("OPE IoU=0 frames", "ope_zero_iou", "d"),
              ("SRE mean AUC", "sre_auc", ".3f"), ("SRE mean P@20", "sre_precision_20", ".3f"),
              ("SRE spread (max-min, mean)", "sre_spread", ".3f"),
              ("SRE spread vs the carried start box", "sre_carried_spread", ".3f"),
              ("SRE AUC vs the carried start box", "sre_carried_mean", ".3f"),
              ("SRE spread of exact tracking (floor)", "sre_floor_spread", ".3f"),
              ("SRE false tracking (all runs)", "sre_false_tracking", "d"),
              ("SRE IoU=0 frames (all runs)", "sre_zero_iou", "d"), ("fps (OPE, mean)", "fps", ".1f"))

Table = tuple[str, str, list[tuple[str, list[str]]]]  # (title, label column, [(label, a cell per tracker)])


def protocol_tables(result: ProtocolResult) -> list[Table]:
    """The protocol's tables, trackers side by side: per group of sequences the per-sequence OPE and SRE
    tables, then the means (and occlusions survived on the synthetic group). Both renderers lay these out."""
    tr = result.trackers
    tables: list[Table] = []
    for group, seqs in result.groups().items():
        title = "real sequences" if group == "real" else "synthetic scenarios"
        if "ope" in result.protocols:
            rows = []
            for s in seqs:
                runs = [result.stats[s][t].get("none") for t in tr]
                rows.append((s, ["-" if r is None else f"{r.success_auc:.3f} / {r.precision_20:.2f} / "
                                 f"{r.false_tracking}" for r in runs]))
            tables.append((f"OPE {title}: AUC / P@20 / FT", "sequence", rows))
        if "sre" in result.protocols:
            rows = []
            for s in seqs:
                sre = [result.sre(s, t) for t in tr]
                rows.append((s, ["-" if v is None else f"{v['mean']:.3f} [{v['min']:.3f}, {v['max']:.3f}]"
                                 for v in sre]))
            tables.append((f"SRE {title}: AUC mean [min, max] over the starts", "sequence", rows))
        summ = [result.summary(t, seqs) for t in tr]
        rows = [(name, [_f(m.get(key), fmt) for m in summ])
                for name, key, fmt in _MEAN_ROWS if any(key in m for m in summ)]
        if group == "synth":
            for proto, pre in (("OPE", "ope"), ("SRE", "sre")):
                if any(f"{pre}_occlusions" in m for m in summ):
                    counts = [(m.get(f"{pre}_occlusions"), m.get(f"{pre}_survived")) for m in summ]
                    rows.append((f"{proto} occlusions survived",
                                 ["-" if not n else f"{k}/{n} ({100.0 * k / n:.0f} %)" for n, k in counts]))
        tables.append((f"MEAN {title} ({len(seqs)})", "", rows))
    return tables


def _footer(result: ProtocolResult) -> str:
    return (f"commit {result.meta.get('commit')}, OpenCV {result.meta.get('opencv', '-')}, SRE style "
            f"{result.meta.get('style')}, FT = frames in state tracking (OpenCV: ok) with IoU 0; "
            "frames after the start frame scored")


def format_protocol(result: ProtocolResult) -> str:
    """`protocol_tables` as fixed-width text (the harness's console output)."""
    out: list[str] = []
    w = 22
    for title, _, rows in protocol_tables(result):
        head = f"{title:<44}" + "".join(f"{t:>{w}}" for t in result.trackers)
        out += [head, "-" * len(head)]
        out += [f"{label:<44}" + "".join(f"{c:>{w}}" for c in cells) for label, cells in rows]
        out.append("")
    out.append(_footer(result))
    return "\n".join(out)


def format_markdown(result: ProtocolResult) -> str:
    """`protocol_tables` in Markdown (for docs and issue notes)."""
    tr = result.trackers
    out: list[str] = []
    for title, column, rows in protocol_tables(result):
        out += [title, "", f"| {column} | " + " | ".join(tr) + " |", "|---|" + "---|" * len(tr)]
        out += [f"| {label} | " + " | ".join(cells) + " |" for label, cells in rows]
        out.append("")
    out.append(_footer(result))
    return "\n".join(out)
