# SPDX-License-Identifier: Apache-2.0
"""OpenCV's KCF, CSRT and MOSSE next to our variants, run in the separate .venv-bench as subprocesses."""

from __future__ import annotations

import json
import os
import subprocess
from collections.abc import Callable, Sequence
from pathlib import Path

from ..errors import HarnessError
from ..types import Box
from .evaluate import EvalResult
from .metrics import score
from .sources import Source

REPO = Path(__file__).resolve().parents[2]
BENCH = REPO / ".venv-bench"
OPENCV_TRACKERS = ("KCF", "CSRT", "MOSSE")


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


def _spec(src: Source) -> str:
    return f"synth:{src.location}" if src.kind == "synth" else src.location


def run_opencv(src: Source, tracker: str, py: Path, timeout: float = 1800.0) -> tuple[str, object]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    cmd = [str(py), "-m", "swir_tracker_ros.harness.bench_worker", _spec(src), "--tracker", tracker]
    if src.max_frames:
        cmd += ["--frames", str(src.max_frames)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise HarnessError(f"OpenCV {tracker} on {src.name} took longer than {timeout:.0f} s") from None
    if proc.returncode != 0:
        raise HarnessError(f"OpenCV {tracker} on {src.name} failed: {proc.stderr.strip()[-1500:]}")
    data = json.loads(proc.stdout)

    def box(v: list | None) -> Box | None:
        return None if v is None else Box(*v)

    pred = [box(v) for v in data["pred"]]
    gt = [box(v) for v in data["gt"]]
    return f"opencv_{tracker.lower()}", score(pred, gt, data["seconds"], data["occluded"])


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
