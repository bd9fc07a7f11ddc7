# SPDX-License-Identifier: Apache-2.0
"""Speed of the tracking core vs OpenCV's TrackerKCF / TrackerCSRT on the same 576x504 SWIR-like frames.

Run from the repository root: ``.venv/bin/python benchmarks/core_speed.py [--frames N]``. The OpenCV part
runs in the separate benchmark venv (``make bench-venv``, opencv-contrib) as a subprocess on the same
frames, saved to a temporary .npy file. Everything runs on one thread. The last line printed is one JSON
object with normal_fps, occlusion_fps, opencv_kcf_fps and opencv_csrt_fps (wall clock, decoding excluded).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
BENCH_PY = REPO / ".venv-bench" / "bin" / "python"
WIDTH, HEIGHT = 576, 504  # the dissertation's SWIR camera
BOX = (200.0, 200.0, 24.0, 72.0)  # a pedestrian at 70-200 m: area 1728 px (dissertation range 196-15315)


def make_frames(n: int, seed: int = 7) -> np.ndarray:
    """Deterministic 16-bit SWIR-like sequence: low-contrast texture, noise, dead pixels, a walking target."""
    import cv2

    rng = np.random.default_rng(seed)
    bg = cv2.GaussianBlur(rng.random((HEIGHT, WIDTH)).astype(np.float32), (0, 0), 4)
    bg = 0.3 + 0.2 * (bg - bg.min()) / (bg.max() - bg.min())
    tgt = 0.15 + 0.7 * cv2.resize(
        rng.random((12, 4)).astype(np.float32), (24, 72), interpolation=cv2.INTER_NEAREST
    )
    dead = rng.integers(0, WIDTH * HEIGHT, 200)
    frames = np.empty((n, HEIGHT, WIDTH), np.uint16)
    x, y = BOX[0], BOX[1]
    for k in range(n):
        x += 1.5 + 0.5 * np.sin(k / 15.0)
        y += 0.4 * np.cos(k / 20.0)
        if x > WIDTH - 60:
            x = 40.0
        f = bg.copy()
        xi, yi = round(x), round(y)
        f[yi : yi + 72, xi : xi + 24] = tgt
        f += rng.normal(0, 0.01, f.shape).astype(np.float32)
        img = np.clip(20000 + 16000 * f, 0, 65535).astype(np.uint16)
        img.reshape(-1)[dead] = 65535
        frames[k] = img
    return frames


def to8bit(frames: np.ndarray) -> np.ndarray:
    """Global min-max stretch to 8 bit for OpenCV (done once, outside the timed loop)."""
    lo, hi = np.percentile(frames[0], [0.5, 99.5])
    return np.clip((frames.astype(np.float32) - lo) * (255.0 / (hi - lo)), 0, 255).astype(np.uint8)


def time_ours(frames: np.ndarray, occlusion: bool) -> tuple[float, float, float]:
    """(wall fps, cpu fps, fraction of frames in the requested search mode) of our tracker."""
    from swir_tracker_ros.tracker import Tracker, TrackerParams
    from swir_tracker_ros.types import Box, SearchMode

    # occlusion mode: a PSR threshold no response reaches forces the 3x3 grid on every frame
    params = TrackerParams(max_occluded_frames=100000) if occlusion else TrackerParams()
    if occlusion:
        params.kcf.psr_threshold = 100.0  # every frame fails: the 3x3 re-detection path
    trk = Tracker(params)
    trk.init(frames[0], Box(*BOX))
    want = SearchMode.MULTI_WINDOW if occlusion else SearchMode.NORMAL
    hits = 0
    t0, c0 = time.perf_counter(), time.process_time()
    for f in frames[1:]:
        hits += trk.update(f).search_mode is want
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    n = len(frames) - 1
    return n / wall, n / cpu, hits / n


def opencv_child(path: str) -> None:
    """Runs inside .venv-bench: time TrackerKCF and TrackerCSRT on the saved 8-bit frames; print JSON."""
    import cv2

    cv2.setNumThreads(1)
    frames = np.load(path)
    bgr = [cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    out = {}
    for name, make in (("kcf", cv2.TrackerKCF_create), ("csrt", cv2.TrackerCSRT_create)):
        trk = make()
        trk.init(bgr[0], tuple(int(v) for v in BOX))
        ok_count = 0
        t0, c0 = time.perf_counter(), time.process_time()
        for f in bgr[1:]:
            ok, _ = trk.update(f)
            ok_count += bool(ok)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        n = len(bgr) - 1
        out[name] = {"fps": n / wall, "cpu_fps": n / cpu, "ok": ok_count / n}
    print(json.dumps(out))


def time_opencv(frames8: np.ndarray) -> dict:
    if not BENCH_PY.exists():
        print(f"OpenCV benchmark venv missing ({BENCH_PY}); run `make bench-venv`", file=sys.stderr)
        return {}
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "frames8.npy")
        np.save(path, frames8)
        env = dict(os.environ, PYTHONPATH="")
        proc = subprocess.run(
            [str(BENCH_PY), __file__, "--opencv-child", path],
            capture_output=True,
            text=True,
            env=env,
            check=False,
        )
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
        return {}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--opencv-child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.opencv_child:
        opencv_child(args.opencv_child)
        return
    import cv2

    cv2.setNumThreads(1)
    frames = make_frames(args.frames)
    print(f"{len(frames)} frames {WIDTH}x{HEIGHT} uint16, target {BOX[2]:.0f}x{BOX[3]:.0f} px, one thread")
    n_fps, n_cpu, n_frac = time_ours(frames, occlusion=False)
    o_fps, o_cpu, o_frac = time_ours(frames, occlusion=True)
    print(
        f"ours normal mode (5 scales)      : {n_fps:7.1f} fps wall, {n_cpu:7.1f} fps cpu "
        f"({n_frac:.0%} normal)"
    )
    print(
        f"ours occlusion (5 scales + grid) : {o_fps:7.1f} fps wall, {o_cpu:7.1f} fps cpu ({o_frac:.0%} grid)"
    )
    ocv = time_opencv(to8bit(frames))
    kcf, csrt = ocv.get("kcf", {}), ocv.get("csrt", {})
    for name, r in (("OpenCV TrackerKCF (1 scale, 8 bit)", kcf), ("OpenCV TrackerCSRT (8 bit)", csrt)):
        if r:
            print(f"{name:33s}: {r['fps']:7.1f} fps wall, {r['cpu_fps']:7.1f} fps cpu (ok {r['ok']:.0%})")
    if kcf:
        print(
            f"ratio normal / OpenCV KCF        : {n_fps / kcf['fps']:.2f} (cpu {n_cpu / kcf['cpu_fps']:.2f})"
        )
    if csrt:
        print(
            f"ratio normal / OpenCV CSRT       : {n_fps / csrt['fps']:.2f} "
            f"(cpu {n_cpu / csrt['cpu_fps']:.2f})"
        )
    print(
        f"occlusion mode >= 25 fps         : {'yes' if o_fps >= 25 else 'no'} "
        f"(cpu: {'yes' if o_cpu >= 25 else 'no'})"
    )
    print(
        json.dumps(
            {
                "normal_fps": round(n_fps, 1),
                "occlusion_fps": round(o_fps, 1),
                "opencv_kcf_fps": round(kcf.get("fps", float("nan")), 1),
                "opencv_csrt_fps": round(csrt.get("fps", float("nan")), 1),
                "normal_cpu_fps": round(n_cpu, 1),
                "occlusion_cpu_fps": round(o_cpu, 1),
                "opencv_kcf_cpu_fps": round(kcf.get("cpu_fps", float("nan")), 1),
                "opencv_csrt_cpu_fps": round(csrt.get("cpu_fps", float("nan")), 1),
            }
        )
    )


if __name__ == "__main__":
    main()
