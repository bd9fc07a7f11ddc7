# SPDX-License-Identifier: Apache-2.0
"""OpenCV's KCF, CSRT, MOSSE and Nano (TrackerNano: NanoTrack through OpenCV's DNN module) as peers, run in
the separate .venv-bench by `bench_worker` subprocesses.

Their runs are stored in the results directory like ours (`runner.play`), under the labels `opencv_kcf`,
`opencv_csrt`, `opencv_mosse`, `opencv_nano`; the OpenCV version and the worker's version are their
provenance's code, for Nano also the pinned NanoTrack files it was given (`NANO_VERSION`, found by
core/siamese/locator.py).
"""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Sequence
from functools import lru_cache
from pathlib import Path

from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.params import VERSIONS as SIAMESE_VERSIONS
from swir_tracker_ros.errors import HarnessError, ModelError
from swir_tracker_ros.harness.bench_worker import WORKER_VERSION
from swir_tracker_ros.harness.evaluate import OPE, Run
from swir_tracker_ros.harness.sources import Source
from swir_tracker_ros.harness.store import REPO
from swir_tracker_ros.types import Box

BENCH = REPO / ".venv-bench"
OPENCV_TRACKERS = ("KCF", "CSRT", "MOSSE", "Nano")
OPENCV_DEFAULT = ("KCF", "CSRT", "MOSSE")  # what a plain `harness compare` plays beside ours
NANO_VERSION = "v2"  # the NanoTrack weights OpenCV's TrackerNano is given (the pinned v2 ONNX files)
PEER_PREFIX = "opencv_"


def opencv_label(tracker: str) -> str:
    """The stored-run label of an OpenCV tracker: `opencv_csrt` for CSRT."""
    if tracker not in OPENCV_TRACKERS:
        raise HarnessError(f"unknown OpenCV tracker {tracker!r}; choose from {', '.join(OPENCV_TRACKERS)}")
    return PEER_PREFIX + tracker.lower()


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
    """cv2.__version__ of the benchmark interpreter (part of the peers' provenance)."""
    proc = subprocess.run([str(py), "-c", "import cv2; print(cv2.__version__)"], capture_output=True,
                          text=True)
    if proc.returncode != 0:
        raise HarnessError(f"{py}: cannot import cv2: {proc.stderr.strip()[-500:]}")
    return proc.stdout.strip()


def nano_models() -> dict[str, str]:
    """The backbone and neck-head ONNX files of `NANO_VERSION` (checked by the locator); HarnessError when
    they are missing or corrupt."""
    pin = SIAMESE_VERSIONS[NANO_VERSION]
    try:
        return {"backbone": str(locate(pin.backbone)), "neckhead": str(locate(pin.head))}
    except ModelError as exc:
        raise HarnessError(str(exc)) from None


def opencv_code(py: Path, tracker: str | None = None) -> str:
    """What produces an OpenCV peer's boxes: the OpenCV build and the worker's version (Nano: and the
    pinned NanoTrack version it is given)."""
    code = f"opencv-{opencv_version(py)}/bench_worker-{WORKER_VERSION}"
    return code + f"/nanotrack-{NANO_VERSION}" if tracker == "Nano" else code


def _spec(src: Source) -> str:
    return f"synth:{src.location}" if src.kind == "synth" else src.location


def _box(v: list | None) -> Box | None:
    return None if v is None else Box(*v)


def run_worker(src: Source, tracker: str, py: Path, starts: Sequence[str] = (OPE,), style: str = "otb",
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


def _worker_json(src: Source, tracker: str, py: Path, starts: Sequence[str], style: str,
                 init: Box | None = None, timeout: float = 7200.0) -> dict:
    if tracker not in OPENCV_TRACKERS:
        raise HarnessError(f"unknown OpenCV tracker {tracker!r}; choose from {', '.join(OPENCV_TRACKERS)}")
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    cmd = [str(py), "-m", "swir_tracker_ros.harness.bench_worker", _spec(src), "--tracker", tracker,
           "--style", style]
    if tracker == "Nano":
        models = nano_models()
        cmd += ["--backbone", models["backbone"], "--neckhead", models["neckhead"]]
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
