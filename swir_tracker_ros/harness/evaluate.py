# SPDX-License-Identifier: Apache-2.0
"""Our tracker under the harness: the one place that builds it from a configuration name, and the loop
that plays it over a source from one or several start boxes (raw per-frame boxes and states)."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from copy import deepcopy
from dataclasses import dataclass, field, fields, is_dataclass, replace
from typing import Protocol

import yaml

from swir_tracker_ros.configs import CONFIGURATIONS, DEFAULT_CONFIGURATION, configuration
from swir_tracker_ros.errors import HarnessError, ParameterError, SwirTrackerError
from swir_tracker_ros.harness.metrics import sre_box
from swir_tracker_ros.harness.sources import Source
from swir_tracker_ros.harness.store import OPE
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.tracker_params import TrackerParams
from swir_tracker_ros.types import Box, TrackResult

DEFAULT = "default"  # the configuration name that stands for the tracker's default configuration
BASE_KEYS = ("pipeline", "base_filter")  # override keys that choose the configuration's base filter


class TrackerLike(Protocol):
    """What the harness needs of a tracker: `init(frame, box)` and `update(frame) -> TrackResult`."""

    def init(self, frame, box: Box, bit_depth: int | None = None) -> None: ...

    def update(self, frame, bit_depth: int | None = None) -> TrackResult: ...


# --- Building trackers: the one place (swap these when the core's configurations change) ---------------

def configurations() -> tuple[str, ...]:
    """Names of the tracker's configurations (swir_tracker_ros/configs/)."""
    return tuple(CONFIGURATIONS)


def default_configuration() -> str:
    """The name of the configuration the tracker runs by default."""
    return DEFAULT_CONFIGURATION


def resolve_configuration(name: str) -> str:
    """`name` itself, or the default configuration's name for "default"; HarnessError listing the known
    names for anything else."""
    if name == DEFAULT:
        return default_configuration()
    if name not in configurations():
        known = ", ".join((*configurations(), DEFAULT))
        raise HarnessError(f"unknown configuration {name!r}; known: {known}")
    return name


def _set_path(obj: object, path: list[str], value: object, full: str) -> object:
    if not is_dataclass(obj) or path[0] not in {f.name for f in fields(obj)}:
        raise HarnessError(f"--set {full}: no such tracker parameter")
    if len(path) == 1:
        return replace(obj, **{path[0]: value})
    return replace(obj, **{path[0]: _set_path(getattr(obj, path[0]), path[1:], value, full)})


def tracker_params(name: str, overrides: Sequence[str] = ()) -> TrackerParams:
    """The parameters of configuration `name` with `overrides` applied: `NAME=VALUE` strings (dotted names
    reach nested parameter dataclasses, VALUE is parsed as YAML; `pipeline=P` or `base_filter=P` builds the
    configuration on base filter P). Validated; a bad name or value is a HarnessError."""
    if isinstance(overrides, str):
        raise HarnessError(f"overrides must be a list of NAME=VALUE strings, got the string {overrides!r}")
    try:
        pairs = []
        for item in overrides:
            key, eq, text = item.partition("=")
            if not eq or not key:
                raise HarnessError(f"--set wants NAME=VALUE, got {item!r}")
            pairs.append((key.strip(), yaml.safe_load(text), item))
        bases = [str(v) for k, v, _ in pairs if k in BASE_KEYS]
        params = configuration(resolve_configuration(name), bases[-1] if bases else None)
        for key, value, item in pairs:
            if key not in BASE_KEYS:
                params = _set_path(params, key.split("."), value, item)
        params.validate()
    except (ParameterError, TypeError, yaml.YAMLError) as exc:
        raise HarnessError(f"tracker parameters: {exc}") from None
    return params


def make_tracker_factory(name: str, overrides: Sequence[str] = ()) -> Callable[[], TrackerLike]:
    """A zero-argument constructor of our tracker in configuration `name` (`tracker_params`)."""
    params = tracker_params(name, overrides)
    return lambda: Tracker(deepcopy(params))


# --- Playing a tracker over a source ----------------------------------------------------------------------

@dataclass
class Run:
    """Per-frame output of one tracker on one source from one start: the boxes and states as the tracker
    reported them (the scoring convention is applied when the run is scored, `protocol.RunStats.of`)."""

    pred: list[Box | None]
    gt: list[Box | None]
    occluded: list[bool | None]
    seconds: float
    states: list[str] = field(default_factory=list)
    occlusion: list[float | None] = field(default_factory=list)  # covered share (synthetic sources)
    init: Box | None = None  # start box
    init_index: int = 0  # frame of the start


def run_starts(source: Source, factory: Callable[[], TrackerLike], starts: Sequence[str] = (OPE,),
               style: str = "otb", init: Box | None = None) -> dict[str, Run]:
    """Run one tracker per start side by side over one decoding of `source` (OPE and SRE starts).

    Each start inits its own tracker on the first frame that has ground truth, with the ground-truth box
    (`none`), an SRE perturbation of it (`metrics.sre_box`, `style`) or the explicit `init` box (key "init"),
    and updates on every later frame; each tracker is timed on its own. Frames before the start have no
    box and state `idle`; every later frame has the box and state the tracker reported.
    """
    keys = ["init"] if init is not None else list(starts)
    trackers: dict[str, TrackerLike] = {}
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
            r.pred.append(res.box)
            r.states.append(res.state.value)
    if not trackers:
        raise HarnessError(f"{source.name}: no frame with ground truth; nothing to track")
    for r in runs.values():
        r.gt, r.occluded, r.occlusion = gts, occ, share
    return runs


def run_source(source: Source, factory: Callable[[], TrackerLike]) -> Run:
    """OPE: init on the first frame that has ground truth, update on every later frame, time the tracker."""
    return run_starts(source, factory)[OPE]
