# SPDX-License-Identifier: Apache-2.0
"""OpenCV's KCF, CSRT and MOSSE next to our variants, run in the separate .venv-bench as subprocesses.

Peer runs are deterministic for a given OpenCV build, worker, sequence and start box, so they can be kept
in an on-disk cache (`PeerCache`): one JSON file per (OpenCV version, tracker, sequence, start), holding the
per-frame boxes and ok flags. `harness compare --protocol` reads and fills it.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from functools import lru_cache
from pathlib import Path

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.bench_worker import WORKER_VERSION
from swir_tracker_ros.harness.evaluate import EvalResult, Run
from swir_tracker_ros.harness.metrics import score
from swir_tracker_ros.harness.sources import Source
from swir_tracker_ros.types import Box

REPO = Path(__file__).resolve().parents[2]
BENCH = REPO / ".venv-bench"
OPENCV_TRACKERS = ("KCF", "CSRT", "MOSSE")
SCENE_DIR = REPO / "swir_tracker_ros" / "scene"


def bench_python(build: bool = True) -> Path:
    """The .venv-bench interpreter; built with `make bench-venv` (requirements-bench.txt) when missing."""
    py = BENCH / "bin" / "python"
    if not (BENCH / ".installed").exists():
        if not build:
            raise HarnessError(f"{BENCH} is missing; run `make bench-venv`")
        proc = subprocess.run(["make", "-C", str(REPO), "bench-venv"], capture_output=True, text=True)
        if proc.returncode != 0:
            raise HarnessError(f"`make bench-venv` failed:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    if not py.exists():
        raise HarnessError(f"{py} does not exist after `make bench-venv`")
    return py


@lru_cache(maxsize=4)
def opencv_version(py: Path) -> str:
    """cv2.__version__ of the benchmark interpreter (part of the peer-cache key)."""
    proc = subprocess.run([str(py), "-c", "import cv2; print(cv2.__version__)"], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise HarnessError(f"{py}: cannot import cv2: {proc.stderr.strip()[-500:]}")
    return proc.stdout.strip()


def _spec(src: Source) -> str:
    return f"synth:{src.location}" if src.kind == "synth" else src.location


def _box(v: list | None) -> Box | None:
    return None if v is None else Box(*v)


def run_worker(src: Source, tracker: str, py: Path, starts: Sequence[str] = ("none",), style: str = "otb",
               init: Box | None = None, timeout: float = 7200.0) -> dict[str, Run]:
    """One bench_worker subprocess: `tracker` from every start in `starts` (or from `init`) over `src`."""
    return runs_from_worker(_worker_json(src, tracker, py, starts, style, init, timeout))


def runs_from_worker(data: dict) -> dict[str, Run]:
    """The worker's JSON as one `Run` per start; `ok` becomes state `tracking`, a failure `lost`."""
    gt = [_box(v) for v in data["gt"]]
    out = {}
    for r in data["runs"]:
        first = next(k for k, v in enumerate(r["pred"]) if v is not None)
        states = ["idle"] * first + ["init"] + ["tracking" if ok else "lost" for ok in r["ok"][first + 1:]]
        out[r["perturbation"]] = Run([_box(v) for v in r["pred"]], gt, list(data["occluded"]), r["seconds"],
                                     states, list(data.get("occlusion") or [None] * len(gt)),
                                     _box(r["init"]), first)
    return out


def source_fingerprint(src: Source) -> str:
    """Content identity of a source for the cache: gt.txt (+ frame count) of a folder, the scene code of a
    synthetic scenario, file names and sizes of a bag; plus the --frames limit."""
    h = hashlib.sha1(f"{src.kind}:{src.name}:{src.max_frames}".encode())
    loc = Path(src.location)
    if src.kind == "sequence":
        lines = [ln for ln in (loc / "gt.txt").read_text().splitlines() if ln.strip()]
        h.update("\n".join(lines[:src.max_frames] if src.max_frames else lines).encode())
        h.update(str(len(list(loc.glob("*.png")))).encode())
    elif src.kind == "synth":
        for f in sorted(SCENE_DIR.glob("*.py")):
            h.update(f.read_bytes())
    else:
        files = sorted(loc.rglob("*")) if loc.is_dir() else [loc]
        for f in files:
            if f.is_file():
                h.update(f"{f.name}:{f.stat().st_size}".encode())
    return h.hexdigest()[:16]


class PeerCache:
    """On-disk results of OpenCV peers, keyed by (OpenCV version, tracker, sequence, start).

    Layout: ROOT/opencv-<version>/<TRACKER>/<sequence>/<start>-<hash>.json, where <start> is `none` (OPE)
    or an SRE perturbation (prefixed `shift-` for the "shift" style) and <hash> covers the whole key
    (`key`): OpenCV version, tracker, sequence name and content fingerprint, start, SRE style, --frames,
    worker version. A file whose stored key differs is ignored and rewritten.
    """

    def __init__(self, root: str | Path | None):
        self.root = None if root is None else Path(root)

    @staticmethod
    def key(opencv: str, tracker: str, src: Source, start: str, style: str = "otb") -> dict:
        return {"opencv": opencv, "tracker": tracker, "sequence": src.name,
                "fingerprint": source_fingerprint(src), "start": start,
                "style": None if start == "none" else style, "frames": src.max_frames,
                "worker": WORKER_VERSION}

    def path(self, key: dict) -> Path:
        if self.root is None:
            raise HarnessError("no peer cache directory")
        digest = hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]
        tag = key["start"] if key["style"] in (None, "otb") else f"{key['style']}-{key['start']}"
        folder = self.root / f"opencv-{key['opencv']}" / key["tracker"] / key["sequence"]
        return folder / f"{tag}-{digest}.json"

    def load(self, key: dict) -> Run | None:
        if self.root is None:
            return None
        p = self.path(key)
        try:
            data = json.loads(p.read_text())
        except (OSError, ValueError):
            return None
        if data.get("key") != key:
            return None
        return runs_from_worker(data)[key["start"]]

    def store(self, key: dict, worker_data: dict, start: str) -> None:
        if self.root is None:
            return
        p = self.path(key)
        p.parent.mkdir(parents=True, exist_ok=True)
        one = {k: v for k, v in worker_data.items() if k != "runs"}
        one["runs"] = [r for r in worker_data["runs"] if r["perturbation"] == start]
        one["key"] = key
        fd, tmp = tempfile.mkstemp(dir=p.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as f:
            json.dump(one, f)
        os.chmod(tmp, 0o644)  # mkstemp makes it private; the cache is shared between worktrees
        os.replace(tmp, p)  # atomic: concurrent runs never see half a file


def peer_runs(src: Source, tracker: str, starts: Sequence[str], style: str, cache: PeerCache, py: Path,
              opencv: str) -> tuple[dict[str, Run], int]:
    """Runs of one OpenCV tracker from every start: cached ones loaded, the rest computed in ONE worker
    process and stored. Returns the runs and how many were computed."""
    out: dict[str, Run] = {}
    keys = {s: PeerCache.key(opencv, tracker, src, s, style) for s in starts}
    for s, k in keys.items():
        run = cache.load(k)
        if run is not None:
            out[s] = run
    missing = [s for s in starts if s not in out]
    if missing:
        data = _worker_json(src, tracker, py, missing, style)
        if data["opencv"] != opencv:
            raise HarnessError(f"the worker ran OpenCV {data['opencv']}, expected {opencv}")
        runs = runs_from_worker(data)
        for s in missing:
            cache.store(keys[s], data, s)
            out[s] = runs[s]
    return {s: out[s] for s in starts}, len(missing)


def _worker_json(src: Source, tracker: str, py: Path, starts: Sequence[str], style: str,
                 init: Box | None = None, timeout: float = 7200.0) -> dict:
    if tracker not in OPENCV_TRACKERS:
        raise HarnessError(f"unknown OpenCV tracker {tracker!r}; choose from {', '.join(OPENCV_TRACKERS)}")
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    cmd = [str(py), "-m", "swir_tracker_ros.harness.bench_worker", _spec(src), "--tracker", tracker,
           "--style", style]
    if init is not None:
        cmd += ["--init", ",".join(repr(v) for v in init.as_tuple())]
    else:
        cmd += ["--perturb", *starts]
    if src.max_frames:
        cmd += ["--frames", str(src.max_frames)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise HarnessError(f"OpenCV {tracker} on {src.name} took longer than {timeout:.0f} s") from None
    if proc.returncode != 0:
        raise HarnessError(f"OpenCV {tracker} on {src.name} failed: {proc.stderr.strip()[-1500:]}")
    return json.loads(proc.stdout)


def run_opencv(src: Source, tracker: str, py: Path, timeout: float = 1800.0) -> tuple[str, object]:
    """OPE of one OpenCV tracker, scored as `harness eval` scores (start frame included)."""
    run = run_worker(src, tracker, py, timeout=timeout)["none"]
    return f"opencv_{tracker.lower()}", score(run.pred, run.gt, run.seconds, run.occluded)


def add_opencv(result: EvalResult, sources: Sequence[Source], trackers: Sequence[str] = OPENCV_TRACKERS,
               progress: Callable[[str], None] | None = None) -> EvalResult:
    """Adds `opencv_kcf`, `opencv_csrt`, `opencv_mosse` rows for every source to `result` (in place)."""
    py = bench_python()
    for src in sources:
        per = result.sequences.setdefault(src.name, {})
        for t in trackers:
            if t not in OPENCV_TRACKERS:
                raise HarnessError(f"unknown OpenCV tracker {t!r}; choose from {', '.join(OPENCV_TRACKERS)}")
            if f"opencv_{t.lower()}" in per:  # reused from an earlier run
                continue
            name, s = run_opencv(src, t, py)
            per[name] = s
            if progress:
                progress(f"{src.name:<32} {name:<18} P@20 {s.precision_20:.3f}  AUC {s.success_auc:.3f}  "
                         f"{s.fps:6.1f} fps")
    return result
