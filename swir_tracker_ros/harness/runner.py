# SPDX-License-Identifier: Apache-2.0
"""The runner: plays (tracker, configuration) over sources and starts and stores every run (`store`).

A run already stored with the same provenance identity (tracker, configuration, overrides, code, numeric
environment, source content, SRE style) is not played again. One stored with a different identity is
stale: the runner stops and names it, unless `rerun` asks to replace it (re-running is an explicit choice;
to keep both, store the new runs under another label or results directory).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from functools import lru_cache
from multiprocessing import get_context
from pathlib import Path

from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.params import VERSIONS as SIAMESE_VERSIONS
from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.errors import HarnessError, ModelError, ParameterError
from swir_tracker_ros.harness.compare import (
    NANO_VERSION,
    bench_python,
    nano_models,
    opencv_code,
    opencv_label,
    run_worker,
)
from swir_tracker_ros.harness.evaluate import (
    OPE,
    Run,
    make_tracker_factory,
    resolve_configuration,
    run_starts,
    tracker_params,
)
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS, SRE_STYLES
from swir_tracker_ros.harness.sources import Source, frame_files, read_frame, source_fingerprint
from swir_tracker_ros.harness.store import (
    RunRecord,
    RunStore,
    Truth,
    code_hash,
    differences,
    git_commit,
    numerics,
)

PROTOCOLS = ("ope", "sre")
WHOLE_PIXEL = "-wholepixel"  # Siamese configuration suffix: the authors' whole-pixel crops
INT8 = "-int8"  # Siamese configuration suffix: the int8 heads (SiameseParams.precision)
_COST = {"CSRT": 0, "swir": 1, "Nano": 2, "KCF": 3, "MOSSE": 4}  # slowest first (better packing on --jobs)


def protocol_starts(protocols: Sequence[str]) -> tuple[str, ...]:
    """The starts of `protocols`: OPE's ground-truth box, SRE's 12 perturbations."""
    bad = [p for p in protocols if p not in PROTOCOLS]
    if bad or not protocols:
        raise HarnessError(f"unknown protocol {bad}; choose from {', '.join(PROTOCOLS)}")
    return ((OPE,) if "ope" in protocols else ()) + (SRE_PERTURBATIONS if "sre" in protocols else ())


def overrides_label(configuration: str, overrides: Sequence[str]) -> str:
    """The default label of a configuration: its name, plus `+<hash>` of its overrides when it has some."""
    if not overrides:
        return configuration
    return configuration + "+" + hashlib.sha1("\n".join(overrides).encode()).hexdigest()[:6]


@dataclass(frozen=True)
class Player:
    """Who is played: our tracker in a configuration (tracker `swir`), our Siamese network tracker alone
    (`network`, configuration = model version) or an OpenCV tracker (`opencv`)."""

    label: str
    tracker: str  # "swir", "network" (the standalone Siamese tracker) or "opencv"
    configuration: str  # our configuration's name, the Siamese model version (v2), or the OpenCV tracker's
    overrides: tuple[str, ...] = ()

    @classmethod
    def ours(cls, name: str, overrides: Sequence[str] = (), label: str | None = None) -> Player:
        """Our tracker in configuration `name` ("default" resolves to the default's own name); checked."""
        conf = resolve_configuration(name)
        make_tracker_factory(conf, overrides)  # fail now on a bad override, not in a pool worker
        return cls(label or overrides_label(conf, overrides), "swir", conf, tuple(overrides))

    @classmethod
    def opencv(cls, tracker: str) -> Player:
        """An OpenCV tracker (compare.OPENCV_TRACKERS); Nano's model files are checked now."""
        if tracker == "Nano":
            nano_models()  # fail now on missing weights, not in a pool worker
        return cls(opencv_label(tracker), "opencv", tracker)

    @classmethod
    def siamese(cls, version: str, whole_pixel: bool = False, precision: str = "float32") -> Player:
        """The Siamese tracker (core/siamese) with NanoTrack weights `version`, label `siamese_<version>`;
        `whole_pixel`: with the authors' whole-pixel crops (SiameseParams.subpixel_crops False), label
        `siamese_<version>_wholepixel`; `precision` "int8": the int8 heads, label `..._int8`."""
        if version not in SIAMESE_VERSIONS:
            raise HarnessError(f"unknown Siamese model version {version!r}; known: "
                               f"{', '.join(SIAMESE_VERSIONS)}")
        try:  # fail now on missing weights, not in a pool worker
            for rel in SIAMESE_VERSIONS[version].files_for(precision):
                locate(rel)
        except (ModelError, ParameterError) as exc:
            raise HarnessError(str(exc)) from None
        conf = version + (WHOLE_PIXEL if whole_pixel else "") + (INT8 if precision == "int8" else "")
        return cls(f"siamese_{conf.replace('-', '_')}", "network", conf)

    def code(self) -> str:
        return opencv_code(bench_python(), self.configuration) if self.tracker == "opencv" else code_hash()

    def parameters(self) -> dict:
        """The parameters the player runs with, as JSON: information in the provenance (the configuration,
        its overrides and the code decide them)."""
        return _parameters(self.tracker, self.configuration, self.overrides)

    def provenance(self, src: Source, style: str | None) -> dict:
        return {"tracker": self.tracker, "configuration": self.configuration,
                "overrides": list(self.overrides),
                "code": self.code(), "numerics": numerics(), "fingerprint": source_fingerprint(src),
                "style": style, "commit": git_commit(), "frames": src.max_frames,
                "parameters": self.parameters()}


def siamese_params(configuration: str) -> SiameseParams:
    """The Siamese tracker's parameters of a network player's configuration (`v2`, `v2-wholepixel`,
    `lighttrack-int8`, `v3-wholepixel-int8`)."""
    version, *modes = configuration.split("-")
    return SiameseParams(version=version, subpixel_crops=WHOLE_PIXEL[1:] not in modes,
                         precision="int8" if INT8[1:] in modes else "float32")


@lru_cache(maxsize=32)
def _parameters(tracker: str, configuration: str, overrides: tuple[str, ...]) -> dict:
    if tracker == "swir":
        params: object = tracker_params(configuration, overrides)
    elif tracker == "network":
        params = siamese_params(configuration)
    else:
        return {"opencv": configuration, **({"nanotrack": NANO_VERSION} if configuration == "Nano" else {})}
    return json.loads(json.dumps(asdict(params), default=str))


def _style_of(start: str, style: str) -> str | None:
    return None if start == OPE else style


def kind_of(src: Source) -> str:
    """"synth" for a synthetic scenario (also as a bag written by `harness synth`), else "real"."""
    return "synth" if src.kind == "synth" or src.meta.get("kind") == "synth" else "real"


def frame_size(src: Source) -> tuple[int, int]:
    """(width, height) of the source's first frame."""
    if src.kind == "sequence":
        files = frame_files(Path(src.location))
        image = read_frame(files[0]) if files else None
    else:
        first = next(iter(src.frames()), None)
        image = None if first is None else first.image
    if image is None:
        raise HarnessError(f"{src.location}: no frames")
    return int(image.shape[1]), int(image.shape[0])


def truth_of(src: Source, run: Run) -> Truth:
    """The truth to store for a source: a run's ground truth, occlusion flags and shares, fps, frame size."""
    share = run.occlusion or [None] * len(run.gt)
    w, h = frame_size(src)
    return Truth(src.key, kind_of(src), src.fps, list(run.gt), list(run.occluded), list(share), w, h,
                 source_fingerprint(src))


@dataclass(frozen=True)
class Task:
    """One player on one source from the starts it still lacks (run side by side in one process)."""

    player: Player
    source: Source
    starts: tuple[str, ...]
    style: str
    root: str

    @property
    def order(self) -> tuple[bool, int]:
        return (kind_of(self.source) == "synth",
                _COST.get(self.player.configuration if self.player.tracker == "opencv" else "swir", 1))


@dataclass
class TaskReport:
    label: str
    sequence: str
    runs: int
    seconds: float  # wall time of the task


def execute(task: Task) -> TaskReport:
    """Play one task and store its runs and the source's truth (in a pool worker or inline)."""
    t0 = time.perf_counter()
    p, src = task.player, task.source
    if p.tracker == "swir":
        runs = run_starts(src, make_tracker_factory(p.configuration, p.overrides), task.starts, task.style)
    elif p.tracker == "network":
        params = siamese_params(p.configuration)
        runs = run_starts(src, lambda: SiameseTracker(params), task.starts, task.style)
    else:
        runs = run_worker(src, p.configuration, bench_python(), task.starts, task.style)
    store = RunStore(task.root)
    truth = truth_of(src, next(iter(runs.values())))
    old = store.load_truth(src.key)
    if old is None or old.fingerprint != truth.fingerprint or old.gt != truth.gt:
        store.save_truth(truth)
    created = datetime.now(timezone.utc).isoformat(timespec="seconds")
    for start, run in runs.items():
        style = _style_of(start, task.style)
        prov = dict(p.provenance(src, style), created=created)
        store.save(RunRecord(p.label, src.key, start, style, run.pred, run.states, run.seconds, run.init,
                             run.init_index, prov))
    return TaskReport(p.label, src.key, len(runs), time.perf_counter() - t0)


@dataclass
class PlayReport:
    computed: int  # runs played now
    reused: int  # runs taken from the store
    replaced: int  # stale runs played again (rerun)


def plan(sources: Sequence[Source], players: Sequence[Player], starts: Sequence[str], style: str,
         store: RunStore, rerun: bool = False) -> tuple[list[Task], PlayReport]:
    """The tasks still to play; HarnessError naming the stale runs when some are stale and not `rerun`."""
    if style not in SRE_STYLES:
        raise HarnessError(f"SRE style {style!r}; choose from {', '.join(SRE_STYLES)}")
    keys = [s.key for s in sources]
    dup = sorted({k for k in keys if keys.count(k) > 1})
    if dup:
        raise HarnessError(f"two sources are both called {dup[0]!r}")
    tasks, stale, report = [], [], PlayReport(0, 0, 0)
    for src in sources:
        truth = store.load_truth(src.key)
        if truth is not None and truth.fingerprint != source_fingerprint(src) and not rerun:
            raise HarnessError(f"{store.root} holds {src.key} from other content than {src.location} "
                               "(another source of that name, or changed frames): use another --results, or "
                               "--rerun")
        for p in players:
            todo = []
            base = p.provenance(src, None)
            for start in starts:
                rec = store.load(p.label, src.key, start, _style_of(start, style))
                wanted = dict(base, style=_style_of(start, style))
                diff = [] if rec is None else differences(rec.provenance, wanted)
                if rec is None:
                    todo.append(start)
                elif diff:
                    stale.append((p.label, src.key, start, diff))
                    todo.append(start)
                else:
                    report.reused += 1
            if todo:
                tasks.append(Task(p, src, tuple(todo), style, str(store.root)))
    if stale and not rerun:
        label, seq, start, diff = stale[0]
        raise HarnessError(
            f"{len(stale)} stored run(s) in {store.root} were made differently, e.g. {label} on {seq} from "
            f"{start} ({'; '.join(diff)}): pass --rerun to play them again and replace them, or store the "
            f"new runs apart (--label NAME or --results DIR)")
    report.replaced = len(stale)
    report.computed = sum(len(t.starts) for t in tasks)
    return sorted(tasks, key=lambda t: t.order), report


def play(sources: Sequence[Source], players: Sequence[Player], starts: Sequence[str], style: str,
         store: RunStore, jobs: int = 1, rerun: bool = False,
         progress: Callable[[str], None] | None = None) -> PlayReport:
    """Store every player's run on every source from every start that is not stored yet (`plan`).

    `jobs` > 1 plays the (player, source) tasks in a process pool of that size."""
    if jobs < 1:
        raise HarnessError(f"--jobs must be at least 1, got {jobs}")
    tasks, report = plan(sources, players, starts, style, store, rerun)
    if progress and report.reused:
        progress(f"{report.reused} run(s) taken from {store.root}")

    def done(r: TaskReport) -> None:
        if progress:
            progress(f"{r.sequence:<28} {r.label:<22} {r.runs:3d} run(s) stored ({r.seconds:.0f} s)")

    if jobs == 1 or len(tasks) <= 1:
        for t in tasks:
            done(execute(t))
    else:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=get_context("spawn")) as pool:
            futures = [pool.submit(execute, t) for t in tasks]
            for fut in as_completed(futures):
                done(fut.result())
    return report
