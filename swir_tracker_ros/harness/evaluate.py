# SPDX-License-Identifier: Apache-2.0
"""One-pass evaluation: replay sources through tracker variants as fast as possible and score them."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from copy import deepcopy
from dataclasses import dataclass, field, fields, is_dataclass, replace

import numpy as np

from swir_tracker_ros.errors import HarnessError, SwirTrackerError
from swir_tracker_ros.harness.metrics import Score, mean_scores, score, sre_box
from swir_tracker_ros.harness.sources import Source
from swir_tracker_ros.types import Box, TrackState

SUMMARY_FIELDS = ("precision_20", "success_auc", "center_error", "lost_frames", "fps")


@dataclass
class Run:
    """Per-frame output of one tracker on one source."""

    pred: list[Box | None]
    gt: list[Box | None]
    occluded: list[bool | None]
    seconds: float
    states: list[str] = field(default_factory=list)
    occlusion: list[float | None] = field(default_factory=list)  # covered share (synthetic sources)
    init: Box | None = None  # start box
    init_index: int = 0  # frame of the start

    def score(self) -> Score:
        return score(self.pred, self.gt, self.seconds, self.occluded)


@dataclass
class EvalResult:
    """Scores by sequence and variant, and the per-sequence mean by variant."""

    sequences: dict[str, dict[str, Score]] = field(default_factory=dict)

    @property
    def variants(self) -> list[str]:
        seen: list[str] = []
        for per in self.sequences.values():
            seen += [v for v in per if v not in seen]
        return seen

    def mean(self) -> dict[str, Score]:
        out = {}
        for v in self.variants:
            scores = [per[v] for per in self.sequences.values() if v in per]
            out[v] = mean_scores(scores)
        return out

    @classmethod
    def from_json(cls, data: dict) -> EvalResult:
        """Inverse of `to_json(curves=True)` (per-sequence rows; the mean is recomputed)."""
        def unpack(d: dict) -> Score:
            if "precision_curve" not in d:
                raise HarnessError("a reused result needs its curves: write it with --json ... --curves")
            vals = {k: (math.inf if v is None and k == "center_error" else v) for k, v in d.items()}
            return Score(**vals)

        return cls({n: {v: unpack(d) for v, d in per.items()} for n, per in data["sequences"].items()})

    def merge(self, other: EvalResult) -> EvalResult:
        for name, per in other.sequences.items():
            self.sequences.setdefault(name, {}).update(per)
        return self

    def to_json(self, curves: bool = False) -> dict:
        def pack(s: Score) -> dict:
            d = s.summary()
            if curves:
                d["precision_curve"], d["success_curve"] = s.precision_curve, s.success_curve
            return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}

        return {"sequences": {n: {v: pack(s) for v, s in per.items()} for n, per in self.sequences.items()},
                "mean": {v: pack(s) for v, s in self.mean().items()}}


def _set_path(obj: object, path: list[str], value: object, full: str) -> object:
    if not is_dataclass(obj) or path[0] not in {f.name for f in fields(obj)}:
        raise HarnessError(f"--set {full}: no such tracker parameter")
    if len(path) == 1:
        return replace(obj, **{path[0]: value})
    return replace(obj, **{path[0]: _set_path(getattr(obj, path[0]), path[1:], value, full)})


def tracker_params(variant: str, pipeline: str | None = None, overrides: Sequence[str] = ()) -> object:
    """`TrackerParams` of the named configuration `variant` (configs/): `pipeline` the base filter (None: the
    configuration's own); `overrides` are `NAME=VALUE` strings (dotted names reach nested parameter
    dataclasses, VALUE is parsed as YAML). Validated; a bad name or value is a HarnessError."""
    import yaml

    from swir_tracker_ros.configs import configuration
    from swir_tracker_ros.errors import ParameterError

    try:
        params = configuration(variant, pipeline)
        for item in overrides:
            name, eq, text = item.partition("=")
            if not eq or not name:
                raise HarnessError(f"--set wants NAME=VALUE, got {item!r}")
            params = _set_path(params, name.strip().split("."), yaml.safe_load(text), item)
        params.validate()
    except (ParameterError, TypeError, yaml.YAMLError) as exc:
        raise HarnessError(f"tracker parameters: {exc}") from None
    return params


def make_tracker_factory(variant: str, pipeline: str | None = None,
                         overrides: Sequence[str] = ()) -> Callable[[], object]:
    """A zero-argument constructor of the core `Tracker` for one variant (`tracker_params`)."""
    from swir_tracker_ros.tracker import Tracker

    params = tracker_params(variant, pipeline, overrides)
    return lambda: Tracker(deepcopy(params))


def run_starts(source: Source, factory: Callable[[], object], starts: Sequence[str] = ("none",),
               style: str = "otb", init: Box | None = None) -> dict[str, Run]:
    """Run one tracker per start side by side over one decoding of `source` (OPE and SRE starts).

    Each start inits its own tracker on the first frame that has ground truth, with the ground-truth box
    (`none`), an SRE perturbation of it (`metrics.sre_box`, `style`) or the explicit `init` box (key "init"),
    and updates on every later frame; each tracker is timed on its own.
    """
    keys = ["init"] if init is not None else list(starts)
    trackers: dict[str, object] = {}
    runs = {k: Run([], [], [], 0.0, []) for k in keys}
    gts: list[Box | None] = []
    occ: list[bool | None] = []
    share: list[float | None] = []
    depth = source.bits if source.bits not in (None, 8, 16) else None
    for fr in source.frames():
        gts.append(fr.gt)
        occ.append(fr.occluded)
        share.append(getattr(fr, "occlusion", None))
        if not trackers:
            if fr.gt is None:
                for r in runs.values():
                    r.pred.append(None)
                    r.states.append("idle")
                continue
            h, w = fr.image.shape[:2]
            for k, r in runs.items():
                box = init if init is not None else sre_box(fr.gt, k, w, h, style)
                trk = factory()
                t0 = time.perf_counter()
                try:
                    trk.init(fr.image, box, bit_depth=depth)
                except SwirTrackerError as exc:
                    raise HarnessError(f"{source.name}: tracker init failed on frame {fr.index}: "
                                       f"{exc}") from None
                r.seconds += time.perf_counter() - t0
                r.pred.append(box)
                r.states.append("init")
                r.init, r.init_index = box, len(gts) - 1
                trackers[k] = trk
            continue
        for k, trk in trackers.items():
            r = runs[k]
            t0 = time.perf_counter()
            try:
                res = trk.update(fr.image, bit_depth=depth)
            except SwirTrackerError as exc:
                raise HarnessError(f"{source.name}: tracker update failed on frame {fr.index}: "
                                   f"{exc}") from None
            r.seconds += time.perf_counter() - t0
            lost = res.state in (TrackState.LOST, TrackState.IDLE) or not res.box.is_valid()
            r.pred.append(None if lost else res.box)
            r.states.append(res.state.value)
    if not trackers:
        raise HarnessError(f"{source.name}: no frame with ground truth; nothing to track")
    for r in runs.values():
        r.gt, r.occluded, r.occlusion = gts, occ, share
    return runs


def run_source(source: Source, factory: Callable[[], object]) -> Run:
    """OPE: init on the first frame that has ground truth, update on every later frame, time the tracker."""
    return run_starts(source, factory)["none"]


def evaluate(sources: Sequence[Source], variants: Sequence[str], pipeline: str | None = None,
             progress: Callable[[str], None] | None = None, reuse: EvalResult | None = None,
             overrides: Sequence[str] = ()) -> EvalResult:
    """Score every variant on every source (sequence names must be unique); rows in `reuse` are kept."""
    result = EvalResult()
    factories: dict[str, Callable[[], object]] = {}  # one validated TrackerParams per variant, built once
    for src in sources:
        if src.name in result.sequences:
            raise HarnessError(f"two sources are both called {src.name!r}")
        result.sequences[src.name] = {}
        for v in variants:
            if reuse is not None and v in reuse.sequences.get(src.name, {}):
                result.sequences[src.name][v] = reuse.sequences[src.name][v]
                continue
            if v not in factories:
                factories[v] = make_tracker_factory(v, pipeline, overrides)
            run = run_source(src, factories[v])
            s = run.score()
            result.sequences[src.name][v] = s
            if progress:
                progress(f"{src.name:<32} {v:<18} P@20 {s.precision_20:.3f}  AUC {s.success_auc:.3f}  "
                         f"{s.fps:6.1f} fps")
    return result


def format_table(result: EvalResult, fields: Sequence[str] = SUMMARY_FIELDS) -> str:
    """Plain-text table: one row per (sequence, variant) and the per-sequence mean at the bottom."""
    head = f"{'sequence':<30} {'variant':<18} " + " ".join(f"{f:>13}" for f in fields)
    lines = [head, "-" * len(head)]

    def row(name: str, v: str, s: Score) -> str:
        cells = []
        for f in fields:
            val = getattr(s, f)
            cells.append(f"{val:>13d}" if isinstance(val, int) else
                         f"{'-':>13}" if val is None or not np.isfinite(val) else f"{val:>13.3f}")
        return f"{name:<30} {v:<18} " + " ".join(cells)

    for name, per in result.sequences.items():
        lines += [row(name, v, s) for v, s in per.items()]
    lines.append("-" * len(head))
    lines += [row("MEAN", v, s) for v, s in result.mean().items()]
    return "\n".join(lines)
