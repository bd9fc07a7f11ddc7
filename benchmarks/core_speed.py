# SPDX-License-Identifier: Apache-2.0
"""Speed of the tracking core vs OpenCV's CSRT and KCF (default and single-channel) on the same frames.

Run from the repository root: ``.venv/bin/python benchmarks/core_speed.py [--frames N]``. Synthetic
576x504 16-bit SWIR-like sequences with a walking target of 24x72, 40x100 and 80x200 pixels; every tracker
runs on one thread (``cv2.setNumThreads(1)``, BLAS/OpenMP at 1). The OpenCV trackers run in the separate
benchmark venv (``make bench-venv``, opencv-contrib) as a subprocess on the same frames (8 bit).

Printed, in order: a micro-benchmark of the OpenCV primitives the runtime uses (both venvs' versions), the
FFT libraries for the filters' real transforms, fps and per-frame p95 of every tracker at every size, a
per-stage profile of our default pipeline (ms per frame; measured in a separate run with timing wrappers
installed around the core's functions, so the timed runs carry no overhead), and as the last line one
JSON object (normal_fps, occlusion_fps, opencv_csrt_fps, opencv_kcf_fps, opencv_kcf_gray_fps at 40x100,
p95_ms_80x200, and the same per size). The Siamese rows (ours v2/v3, core/siamese, and OpenCV's
``cv2.TrackerNano`` as their peer, same weights directory) run on real frames (``SIAMESE_SEQUENCE``);
``--siamese-only`` runs just those.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import functools  # noqa: E402
import importlib  # noqa: E402
import inspect  # noqa: E402
import json  # noqa: E402
import pkgutil  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
BENCH_PY = REPO / ".venv-bench" / "bin" / "python"
MODELS = REPO / "swir_tracker_ros" / "models"
WIDTH, HEIGHT = 576, 504  # the dissertation's SWIR camera
SIZES = ((24, 72), (40, 100), (80, 200))  # target w x h: pedestrians at ~200 m, ~120 m, ~60 m
HEADLINE = (40, 100)
START = (200.0, 150.0)  # top-left corner of the target on the first frame


def make_frames(n: int, size: tuple[int, int], seed: int = 7) -> tuple[np.ndarray, tuple[float, ...]]:
    """Deterministic 16-bit SWIR-like sequence (low-contrast texture, noise, dead pixels, a walking target
    of `size` = (w, h)) and the first frame's box (x, y, w, h)."""
    import cv2

    tw, th = size
    rng = np.random.default_rng(seed)
    bg = cv2.GaussianBlur(rng.random((HEIGHT, WIDTH)).astype(np.float32), (0, 0), 4)
    bg = 0.3 + 0.2 * (bg - bg.min()) / (bg.max() - bg.min())
    tgt = 0.15 + 0.7 * cv2.resize(
        rng.random((12, 4)).astype(np.float32), (tw, th), interpolation=cv2.INTER_NEAREST
    )
    dead = rng.integers(0, WIDTH * HEIGHT, 200)
    frames = np.empty((n, HEIGHT, WIDTH), np.uint16)
    x, y = START
    box = (x, y, float(tw), float(th))
    for k in range(n):
        if k:
            x += 1.5 + 0.5 * np.sin(k / 15.0)
            y += 0.4 * np.cos(k / 20.0)
            if x > WIDTH - tw - 40:
                x = 40.0
        f = bg.copy()
        xi, yi = round(x), round(y)
        f[yi : yi + th, xi : xi + tw] = tgt
        f += rng.normal(0, 0.01, f.shape).astype(np.float32)
        img = np.clip(20000 + 16000 * f, 0, 65535).astype(np.uint16)
        img.reshape(-1)[dead] = 65535
        frames[k] = img
    return frames, box


def to8bit(frames: np.ndarray) -> np.ndarray:
    """Global percentile stretch to 8 bit for OpenCV (done once, outside the timed loop)."""
    lo, hi = np.percentile(frames[0], [0.5, 99.5])
    return np.clip((frames.astype(np.float32) - lo) * (255.0 / (hi - lo)), 0, 255).astype(np.uint8)


def summarise(times: list[float], cpu: float) -> dict:
    """fps (frames / total wall time), cpu_fps (frames / process CPU time: less disturbed by other jobs on
    a shared machine) and per-frame wall p50 / p95 / max in ms."""
    t = np.asarray(times) * 1e3
    return {
        "fps": len(t) / (t.sum() / 1e3),
        "cpu_fps": len(t) / cpu,
        "p50_ms": float(np.percentile(t, 50)),
        "p95_ms": float(np.percentile(t, 95)),
        "max_ms": float(t.max()),
    }


# ---------------------------------------------------------------------------------------------- ours
def warm_up() -> None:
    """Load (on a fresh install: compile) every compiled loop before timing, as the tracker node does at
    start-up; otherwise the first re-detection lattice pays numba's compile inside the timed frames."""
    from swir_tracker_ros.tracker import Tracker

    Tracker.warm_up()


def tracker_params(occlusion: bool, estimator: str | None = None, name: str | None = None):
    """TrackerParams of the configuration `name` (None: the default); `estimator` overrides the default
    filter's scale_estimator (e.g. "dsst")."""
    from swir_tracker_ros.configs import DEFAULT_CONFIGURATION, configuration

    params = configuration(name or DEFAULT_CONFIGURATION)
    if estimator is not None:
        params.base.scale_estimator = estimator
    if occlusion:
        # a PSR threshold no response reaches forces re-detection (the configuration's lattice or grid) every
        # frame; the base filters name their PSR failure threshold differently (KCF, ECO: its PSRs reach
        # 150+ on these clean synthetic targets)
        params.occlusion.max_frames = 100000
        for field, bar in (("psr_threshold", 100.0), ("failure_psr", 1000.0)):
            if hasattr(params.base, field):
                setattr(params.base, field, bar)
    return params


def time_ours(
    frames: np.ndarray, box: tuple[float, ...], occlusion: bool, estimator: str | None = None,
    name: str | None = None,
) -> dict:
    """Per-frame wall times of our tracker in configuration `name` (None: the default); `frac` = share of
    frames in the requested mode."""
    from swir_tracker_ros.tracker import Tracker
    from swir_tracker_ros.types import Box, SearchMode

    warm_up()
    trk = Tracker(tracker_params(occlusion, estimator, name))
    trk.init(frames[0], Box(*box))
    want = SearchMode.MULTI_WINDOW if occlusion else SearchMode.NORMAL
    hits = 0
    times = []
    c0 = time.process_time()
    for f in frames[1:]:
        t0 = time.perf_counter()
        r = trk.update(f)
        times.append(time.perf_counter() - t0)
        hits += r.search_mode is want
    out = summarise(times, time.process_time() - c0)
    out["frac"] = hits / len(times)
    return out


# ---------------------------------------------------------------------------------------------- profile
class StageTimer:
    """Exclusive time per stage: a wrapped call's time minus the time of wrapped calls nested in it, so
    the stages add up to the frame time (the remainder is reported as `other`). Phases (scale search,
    grid, model update) are also summed inclusively. The clock is this thread's CPU time, so other jobs
    on a shared machine do not land in a stage."""

    def __init__(self) -> None:
        self.excl: dict[str, float] = {}
        self.incl: dict[str, float] = {}
        self._stack: list[list[float]] = []  # [start, child time]

    def wrap(self, fn: Callable, stage: str, phase: bool = False) -> Callable:
        if getattr(fn, "_stage_wrapped", False):
            return fn

        @functools.wraps(fn)
        def inner(*args, **kwargs):
            self._stack.append([time.thread_time(), 0.0])
            try:
                return fn(*args, **kwargs)
            finally:
                start, child = self._stack.pop()
                dt = time.thread_time() - start
                self.excl[stage] = self.excl.get(stage, 0.0) + dt - child
                if phase:
                    self.incl[stage] = self.incl.get(stage, 0.0) + dt
                if self._stack:
                    self._stack[-1][1] += dt

        inner._stage_wrapped = True  # type: ignore[attr-defined]
        return inner


# (module, attribute or Class.method, stage, phase?) - looked up by name and skipped when absent, so the
# profile survives refactors of the core; functions imported by name into other modules
# are replaced there too (every loaded swir_tracker_ros module is searched for the same object).
STAGES = (
    ("swir_tracker_ros.core.conditioning", "FrameConditioner.__call__", "conditioning", False),
    ("swir_tracker_ros.core.features", "sample_patch", "sampling", False),
    ("swir_tracker_ros.core.features", "sample_patches", "sampling", False),
    ("swir_tracker_ros.core.features", "unwindowed_features", "features", False),
    ("swir_tracker_ros.core.features", "extract_features", "features", False),
    ("swir_tracker_ros.core.fhog", "fhog", "features", False),
    ("swir_tracker_ros.core.fft", "rfft2", "fft/correlation", False),
    ("swir_tracker_ros.core.fft", "irfft2", "fft/correlation", False),
    ("swir_tracker_ros.core.kcf", "gaussian_correlation", "fft/correlation", False),
    ("swir_tracker_ros.core.fft", "linear_correlation", "fft/correlation", False),
    ("swir_tracker_ros.core.kcf", "KCF.respond", "fft/correlation", False),
    ("swir_tracker_ros.core.dcf_ca", "DCFCA.respond", "fft/correlation", False),
    ("swir_tracker_ros.core.confidence", "analyse", "peak/PSR analysis", False),
    ("swir_tracker_ros.core.confidence", "analyse_batch", "peak/PSR analysis", False),
    ("swir_tracker_ros.core.scale", "scale_patches", "sampling", False),
    ("swir_tracker_ros.core.scale", "ScaleFilter.response", "dsst scale filter", False),
    ("swir_tracker_ros.core.scale", "ScaleFilter.train", "dsst scale filter", False),
    ("swir_tracker_ros.core.template", "TemplateFilter.detect", "scale search", True),
    ("swir_tracker_ros.core.multiwindow", "MultiWindow.detect_grid", "grid", True),
    ("swir_tracker_ros.core.multiwindow", "MultiWindow.detect_lattice", "grid", True),
    ("swir_tracker_ros.core.template", "TemplateFilter.train_memory", "model update", True),
    ("swir_tracker_ros.core.filters", "KCFFilter.train", "model update", True),
    ("swir_tracker_ros.core.filters", "DCFCAFilter.train", "model update", True),
    ("swir_tracker_ros.core.kcf", "KCF.train", "model update", False),
    ("swir_tracker_ros.core.dcf_ca", "DCFCA.train", "model update", False),
)


def install_stage_timers(timer: StageTimer) -> list[tuple[object, str, object]]:
    """Wrap the STAGES functions and every Kalman filter's predict/update; returns what to restore."""
    restore: list[tuple[object, str, object]] = []

    def patch(owner: object, attr: str, stage: str, phase: bool) -> None:
        orig = owner.__dict__.get(attr) if isinstance(owner, type) else getattr(owner, attr, None)
        if orig is None or isinstance(orig, (staticmethod, classmethod)):
            return
        wrapped = timer.wrap(orig, stage, phase)
        restore.append((owner, attr, orig))
        setattr(owner, attr, wrapped)
        if not isinstance(owner, type):  # a module function: replace it where it was imported by name
            for name, mod in list(sys.modules.items()):
                if name.startswith("swir_tracker_ros") and mod is not owner:
                    for k, v in list(vars(mod).items()):
                        if v is orig:
                            restore.append((mod, k, orig))
                            setattr(mod, k, wrapped)

    for modname, path, stage, phase in STAGES:
        try:
            mod = importlib.import_module(modname)
        except ImportError:
            continue
        owner: object = mod
        *cls, attr = path.split(".")
        if cls:
            owner = getattr(mod, cls[0], None)
            if owner is None:
                continue
        patch(owner, attr, stage, phase)
    import swir_tracker_ros.kalman as kalman_pkg

    for info in pkgutil.iter_modules(kalman_pkg.__path__):
        mod = importlib.import_module(f"swir_tracker_ros.kalman.{info.name}")
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ == mod.__name__:
                for meth in ("predict", "update"):
                    if meth in cls.__dict__:
                        patch(cls, meth, "kalman", False)
    return restore


def profile_ours(
    frames: np.ndarray, box: tuple[float, ...], occlusion: bool, estimator: str | None = None
) -> dict[str, float]:
    """ms per frame per stage (exclusive) and per phase (inclusive, keys 'phase: ...')."""
    from swir_tracker_ros.tracker import Tracker
    from swir_tracker_ros.types import Box

    warm_up()
    timer = StageTimer()
    restore = install_stage_timers(timer)
    try:
        trk = Tracker(tracker_params(occlusion, estimator))
        trk.init(frames[0], Box(*box))
        timer.excl.clear()
        timer.incl.clear()
        t0 = time.thread_time()
        for f in frames[1:]:
            trk.update(f)
        total = time.thread_time() - t0
    finally:
        for owner, attr, orig in reversed(restore):
            setattr(owner, attr, orig)
    n = len(frames) - 1
    out = {k: 1e3 * v / n for k, v in sorted(timer.excl.items(), key=lambda kv: -kv[1])}
    out["other"] = 1e3 * (total - sum(timer.excl.values())) / n
    out.update({f"phase: {k}": 1e3 * v / n for k, v in timer.incl.items()})
    out["total"] = 1e3 * total / n
    return out


# ---------------------------------------------------------------------------------------------- primitives
def best_of(fn: Callable[[], object], reps: int = 5, inner: int = 20) -> float:
    """Best mean CPU time in microseconds over `reps` runs of `inner` calls (the least disturbed run)."""
    fn()
    best = float("inf")
    for _ in range(reps):
        t0 = time.process_time()
        for _ in range(inner):
            fn()
        best = min(best, (time.process_time() - t0) / inner)
    return best * 1e6


def primitives(with_dnn: bool = True) -> dict[str, float]:
    """Microseconds per call of the OpenCV primitives the runtime uses (one thread)."""
    import cv2

    cv2.setNumThreads(1)
    rng = np.random.default_rng(1)
    c128 = rng.random((128, 128, 2)).astype(np.float32)
    r128 = rng.random((128, 128)).astype(np.float32)
    frame = rng.random((HEIGHT, WIDTH)).astype(np.float32)
    M = np.array([[1.1, 0.0, 200.3], [0.0, 1.1, 150.7]])
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    out = {
        "version": cv2.__version__,
        "dft 128x128 complex": best_of(lambda: cv2.dft(c128)),
        "dft 128x128 real (CCS)": best_of(lambda: cv2.dft(r128)),
        "mulSpectrums 128x128": best_of(lambda: cv2.mulSpectrums(c128, c128, 0, conjB=True)),
        "warpAffine 576x504 -> 100x248": best_of(
            lambda: cv2.warpAffine(frame, M, (100, 248), flags=flags, borderMode=cv2.BORDER_REPLICATE)
        ),
        "resize 576x504 -> 288x252 AREA": best_of(
            lambda: cv2.resize(frame, (288, 252), interpolation=cv2.INTER_AREA)
        ),
        "Sobel 576x504 f32": best_of(lambda: cv2.Sobel(frame, cv2.CV_32F, 1, 0, ksize=1)),
        "GaussianBlur 576x504 f32 s1": best_of(lambda: cv2.GaussianBlur(frame, (0, 0), 1.0)),
        "cartToPolar 100x248": best_of(lambda: cv2.cartToPolar(frame[:248, :100], frame[:248, 100:200])),
    }
    onnx = MODELS / "siamese_whole.onnx"
    if with_dnn and onnx.is_file():
        net = cv2.dnn.readNetFromONNX(str(onnx))
        net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
        net.setPreferableTarget(cv2.dnn.DNN_TARGET_CPU)
        blob = rng.standard_normal((8, 1, 64, 64)).astype(np.float32)

        def fwd() -> object:
            net.setInput(blob)
            return net.forward()

        out["dnn siamese_whole 8x64x64"] = best_of(fwd, reps=3, inner=5)
    return out


def fft_libraries() -> dict[str, float]:
    """Microseconds of one forward + inverse real 2-D FFT of a (5, 31, 62, 25) FHOG batch (40x100 target,
    5 scales) with scipy.fft, numpy.fft and cv2.dft (per plane), the choice behind core.fft.rfft2 / irfft2."""
    import cv2
    import scipy.fft as sfft

    x = np.random.default_rng(2).random((5, 31, 62, 25)).astype(np.float32)
    shape = x.shape[-2:]

    def scipy_() -> object:
        return sfft.irfft2(sfft.rfft2(x, axes=(-2, -1), workers=1), s=shape, axes=(-2, -1), workers=1)

    def numpy_() -> object:
        return np.fft.irfft2(np.fft.rfft2(x, axes=(-2, -1)), s=shape, axes=(-2, -1))

    flat = x.reshape(-1, *shape)

    def cv2_() -> object:
        return [
            cv2.dft(cv2.dft(p, flags=cv2.DFT_COMPLEX_OUTPUT), flags=cv2.DFT_INVERSE | cv2.DFT_REAL_OUTPUT)
            for p in flat
        ]

    rows = np.ascontiguousarray(flat.reshape(-1, shape[1]))
    nplanes, half = flat.shape[0], shape[1] // 2 + 1

    def cv2_rows() -> object:
        # batched: one DFT_ROWS call over every row of every plane (real -> CCS-free complex), the kept
        # half columns transposed into rows, a second DFT_ROWS call over them; the inverse the same way back
        f = cv2.dft(rows, flags=cv2.DFT_ROWS | cv2.DFT_COMPLEX_OUTPUT)[:, :half]
        cols = np.ascontiguousarray(f.reshape(nplanes, shape[0], half, 2).transpose(0, 2, 1, 3))
        spec = cv2.dft(cols.reshape(-1, shape[0], 2), flags=cv2.DFT_ROWS)
        back = cv2.dft(spec, flags=cv2.DFT_ROWS | cv2.DFT_INVERSE | cv2.DFT_SCALE)
        return back

    from swir_tracker_ros.core import kcf

    def ours() -> object:
        return kcf.irfft2(kcf.rfft2(x), shape)

    def ours_at(rows: int) -> Callable[[], object]:  # the template sizes of the fft_sizes options
        y = np.random.default_rng(2).random((5, 31, rows, 25)).astype(np.float32)
        return lambda: kcf.irfft2(kcf.rfft2(y), (rows, 25))

    return {
        "scipy.fft rfft2+irfft2 (float32)": best_of(scipy_),
        "numpy.fft rfft2+irfft2 (float64)": best_of(numpy_),
        "cv2.dft per plane fwd+inv": best_of(cv2_),
        "cv2.dft DFT_ROWS batched, fwd + col inv only": best_of(cv2_rows),
        "core.fft rfft2+irfft2 (chosen)": best_of(ours),
        "core.kcf at 63 x 25 cells (fft_sizes: smooth7)": best_of(ours_at(63)),
        "core.kcf at 64 x 25 cells (fft_sizes: smooth5)": best_of(ours_at(64)),
    }


# ---------------------------------------------------------------------------------------------- OpenCV
OPENCV_TRACKERS = ("csrt", "kcf", "kcf_gray")


def opencv_child(path: str, box: str) -> None:
    """Runs inside .venv-bench: time CSRT, KCF (default) and KCF (GRAY, compressed_size 1); print JSON."""
    import cv2

    cv2.setNumThreads(1)
    frames = np.load(path)
    bgr = [cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    init_box = tuple(round(float(v)) for v in box.split(","))

    def kcf_gray() -> object:
        # OpenCV's single-channel configuration (gray in both descriptor slots, 1 compressed channel) on
        # the 8-bit gray frames themselves: the fastest OpenCV KCF (other single-channel combinations
        # raise "Matrix operand is an empty matrix" in update, opencv/opencv#22203)
        p = cv2.TrackerKCF_Params()
        p.desc_pca = cv2.TrackerKCF_GRAY
        p.desc_npca = cv2.TrackerKCF_GRAY
        p.compressed_size = 1
        return cv2.TrackerKCF_create(p)

    makers = {"csrt": cv2.TrackerCSRT_create, "kcf": cv2.TrackerKCF_create, "kcf_gray": kcf_gray}
    out: dict[str, object] = {"version": cv2.__version__}
    for name in OPENCV_TRACKERS:
        seq = list(frames) if name == "kcf_gray" else bgr  # CSRT / default KCF use colour names: BGR
        trk = makers[name]()
        trk.init(seq[0], init_box)
        ok_count = 0
        times = []
        c0 = time.process_time()
        for f in seq[1:]:
            t0 = time.perf_counter()
            ok, _ = trk.update(f)
            times.append(time.perf_counter() - t0)
            ok_count += bool(ok)
        r = summarise(times, time.process_time() - c0)
        r["ok"] = ok_count / len(times)
        out[name] = r
    print(json.dumps(out))


def opencv_primitives_child() -> None:
    """Runs inside .venv-bench: the primitive micro-benchmark of that venv's OpenCV (no dnn)."""
    print(json.dumps(primitives(with_dnn=False)))


def run_bench_child(*args: str) -> dict:
    if not BENCH_PY.exists():
        print(f"OpenCV benchmark venv missing ({BENCH_PY}); run `make bench-venv`", file=sys.stderr)
        return {}
    env = dict(os.environ, PYTHONPATH="")
    proc = subprocess.run(
        [str(BENCH_PY), __file__, *args], capture_output=True, text=True, env=env, check=False
    )
    if proc.returncode != 0:
        print(proc.stderr, file=sys.stderr)
        return {}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def time_opencv(frames8: np.ndarray, box: tuple[float, ...]) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "frames8.npy")
        np.save(path, frames8)
        return run_bench_child("--opencv-child", path, "--box", ",".join(str(v) for v in box))


# ---------------------------------------------------------------------------------------------- Siamese
SIAMESE_SEQUENCE = REPO.parent / "shared" / "data" / "sequences" / "antiuav_irclip04"  # 640x512 thermal IR


class AlwaysGone:
    """A gone verdict rejecting every search and candidate: configuration `lead` in re-detection mode."""

    def __init__(self) -> None:
        from swir_tracker_ros.policies.gone import GoneParams

        self.p = GoneParams()

    def judge_cues(self, cues: object) -> bool:
        return True

    def resume_bar(self) -> float:
        return float("inf")


def time_siamese(n: int, seq: Path = SIAMESE_SEQUENCE) -> dict:
    """Our Siamese tracker (core/siamese, v2 and v3) and OpenCV's `cv2.TrackerNano` (the v2 ONNX pair from
    the same model directory) on the same first `n` real frames of `seq` (8-bit gray; TrackerNano gets them
    as BGR, converted outside the timed loop; ours replicates the channel inside it), one thread."""
    import cv2

    from swir_tracker_ros.configs import configuration
    from swir_tracker_ros.core.siamese.locator import locate
    from swir_tracker_ros.core.siamese.params import VERSIONS, SiameseParams
    from swir_tracker_ros.core.siamese.tracker import SiameseTracker
    from swir_tracker_ros.harness.sources import frame_files, read_frame, read_gt
    from swir_tracker_ros.tracker import Tracker

    cv2.setNumThreads(1)
    frames = [read_frame(f) for f in frame_files(seq)[:n]]
    box = read_gt(seq)[0]

    def timed(update, later: list) -> dict:
        times, c0 = [], time.process_time()
        for f in later:
            t0 = time.perf_counter()
            update(f)
            times.append(time.perf_counter() - t0)
        return summarise(times, time.process_time() - c0)

    out: dict[str, dict] = {}
    for version in VERSIONS:
        trk = SiameseTracker(SiameseParams(version=version))
        trk.init(frames[0], box)
        out[f"siamese_{version}"] = timed(trk.update, frames[1:])
    # configuration `fused`: ECO and the v2 network side by side in the long-term tracker (policies/fusion.py)
    fused = Tracker(configuration("fused"))
    fused.init(frames[0], box)
    out["fused"] = timed(fused.update, frames[1:])
    # configuration `lead` (policies/lead.py): tracking, and re-detection mode (a verdict that rejects
    # every frame: the last box's crop and the lattice's next ones on every frame)
    for key, redetect in (("lead", False), ("lead_redetect", True)):
        trk = Tracker(configuration("lead"))
        trk.init(frames[0], box)
        if redetect:
            trk._track.lead.verdict = AlwaysGone()
        out[key] = timed(trk.update, frames[1:])
    # configuration `judged` (policies/second.py): LightTrack-M's opinion on every frame, and on every 4th
    # frame plus the frames whose leader PSR is below 6.4 (the schedule of `judged_sparse`)
    for key, every, doubt in (("judged", 1, 0.0), ("judged_sparse", 4, 6.4)):
        cp = configuration("judged")
        cp = replace(cp, lead=replace(cp.lead, second=replace(cp.lead.second, every=every, doubt_psr=doubt)))
        trk = Tracker(cp)
        trk.init(frames[0], box)
        out[key] = timed(trk.update, frames[1:])
    p = cv2.TrackerNano_Params()
    p.backbone, p.neckhead = str(locate(VERSIONS["v2"].backbone)), str(locate(VERSIONS["v2"].head))
    nano = cv2.TrackerNano_create(p)
    bgr = [cv2.cvtColor(f, cv2.COLOR_GRAY2BGR) for f in frames]
    nano.init(bgr[0], tuple(round(v) for v in box.as_tuple()))
    out["opencv_nano"] = timed(nano.update, bgr[1:])
    return out


SIAMESE_NAMES = {"siamese_v2": "ours Siamese v2 (core/siamese)",
                 "siamese_v3": "ours Siamese v3 (core/siamese)",
                 "fused": "ours, configuration fused (ECO + v2)",
                 "lead": "ours, configuration lead (tracking)",
                 "lead_redetect": "ours, configuration lead (re-detection)",
                 "judged": "ours, configuration judged (second every frame)",
                 "judged_sparse": "ours, judged, second every 4th + doubt",
                 "opencv_nano": "OpenCV TrackerNano (v2 weights)"}


def print_siamese(res: dict, frames: int) -> None:
    from swir_tracker_ros.harness.sources import frame_files, read_frame

    h, w = read_frame(frame_files(SIAMESE_SEQUENCE)[0]).shape[:2]
    print(f"\nSiamese trackers on {SIAMESE_SEQUENCE.name} ({w}x{h}), first {frames} real frames, one thread")
    print("tracker" + " " * 42 + "fps  cpu fps   p50 ms   p95 ms   max ms")
    for key, label in SIAMESE_NAMES.items():
        r = res[key]
        print(f"  {label:46s} {r['fps']:7.1f} {r['cpu_fps']:8.1f} {r['p50_ms']:8.2f} {r['p95_ms']:8.2f} "
              f"{r['max_ms']:8.2f}")
    for key in ("siamese_v2", "siamese_v3", "fused", "lead", "lead_redetect", "judged", "judged_sparse"):
        print(f"  ratio {key} / TrackerNano: {res[key]['fps'] / res['opencv_nano']['fps']:.2f} "
              f"(cpu {res[key]['cpu_fps'] / res['opencv_nano']['cpu_fps']:.2f})")


# ---------------------------------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=150, help="frames per sequence (one per target size)")
    ap.add_argument("--siamese-only", action="store_true",
                    help="only the Siamese rows (ours v2/v3 and cv2.TrackerNano on real frames)")
    ap.add_argument("--opencv-child", help=argparse.SUPPRESS)
    ap.add_argument("--opencv-primitives", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--box", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.opencv_child:
        opencv_child(args.opencv_child, args.box)
        return
    if args.opencv_primitives:
        opencv_primitives_child()
        return
    import cv2

    if args.siamese_only:
        siamese = time_siamese(args.frames)
        print_siamese(siamese, args.frames)
        print(json.dumps({f"{k}_{m}": round(v[m], 2) for k, v in siamese.items() for m in ("fps", "cpu_fps",
                                                                                         "p95_ms")}))
        return
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import eco_speed  # benchmarks/eco_speed.py: the ECO base filter and the ECO-HC port (ECOHC_PORT_DIR)

    cv2.setNumThreads(1)
    print(f"{args.frames} frames {WIDTH}x{HEIGHT} uint16 per target size, one thread")

    print("\nOpenCV primitives (us CPU per call, best of 5)  runtime .venv   bench .venv-bench")
    prim = primitives()
    prim_b = run_bench_child("--opencv-primitives")
    for k, v in prim.items():
        vb = prim_b.get(k, "")
        if k == "version":
            print(f"  {'version':45s} {v:>12s}   {vb:>12s}")
        else:
            vbs = f"{vb:12.1f}" if isinstance(vb, float) else f"{'-':>12s}"
            print(f"  {k:45s} {v:12.1f}   {vbs}")
    print("\nFFT of a (5, 31, 62, 25) FHOG batch, forward + inverse (us CPU, best of 5)")
    ffts = fft_libraries()
    for k, v in ffts.items():
        print(f"  {k:45s} {v:12.1f}")

    results: dict[str, dict] = {}
    profiles: dict[str, dict] = {}
    for size in SIZES:
        tag = f"{size[0]}x{size[1]}"
        frames, box = make_frames(args.frames, size)
        res = {
            "normal": time_ours(frames, box, occlusion=False),
            "occlusion": time_ours(frames, box, occlusion=True),
            "dsst": time_ours(frames, box, occlusion=False, estimator="dsst"),
            "eco_cfg": time_ours(frames, box, occlusion=False, name="eco"),
            "eco_cfg_occ": time_ours(frames, box, occlusion=True, name="eco"),
        }
        res.update(time_opencv(to8bit(frames), box))
        res["eco"] = eco_speed.time_eco(frames, box)  # the ECO base filter, short-term (core/eco)
        port = eco_speed.time_port(to8bit(frames), box)  # the ECO-HC port, where ECOHC_PORT_DIR names it
        if port:
            res["eco_port"] = port
        results[tag] = res
        profiles[tag] = profile_ours(frames, box, occlusion=False)
        if size == HEADLINE:
            profiles[f"{tag} occlusion"] = profile_ours(frames, box, occlusion=True)
            profiles[f"{tag} dsst"] = profile_ours(frames, box, occlusion=False, estimator="dsst")

    names = {
        "normal": "ours normal (5 scales)",
        "occlusion": "ours occlusion (5 scales + re-detection lattice)",
        "dsst": "ours normal, dsst option (1 window)",
        "csrt": "OpenCV CSRT",
        "kcf": "OpenCV KCF default (CN+gray)",
        "kcf_gray": "OpenCV KCF gray, 1 channel",
        "eco_cfg": "ours configuration eco, normal",
        "eco_cfg_occ": "ours configuration eco, occlusion (3x3 grid)",
        "eco": "ours ECO base filter alone (fDSST)",
        "eco_port": "ECO-HC Python port",
    }
    print("\ntracker" + " " * 42 + "size      fps  cpu fps   p50 ms   p95 ms   max ms")
    for tag, res in results.items():
        for key, label in names.items():
            r = res.get(key)
            if r:
                extra = (f"  ({r['frac']:.0%} in mode)" if "frac" in r
                         else f"  (ok {r['ok']:.0%})" if "ok" in r else "")
                print(
                    f"  {label:46s} {tag:7s} {r['fps']:7.1f} {r['cpu_fps']:8.1f} {r['p50_ms']:8.2f} "
                    f"{r['p95_ms']:8.2f} "
                    f"{r['max_ms']:8.2f}{extra}"
                )
    head = results[f"{HEADLINE[0]}x{HEADLINE[1]}"]
    for ours in ("normal", "dsst", "eco_cfg", "eco"):
        for peer in ("csrt", "kcf", "kcf_gray", "eco_port"):
            if peer in head:
                ratio = head[ours]["fps"] / head[peer]["fps"]
                cpu = head[ours]["cpu_fps"] / head[peer]["cpu_fps"]
                print(f"  ratio {ours:7s} / {names[peer]:28s} at 40x100: {ratio:.2f} (cpu {cpu:.2f})")

    siamese = time_siamese(args.frames)
    print_siamese(siamese, args.frames)

    print("\nper-stage profile of the default pipeline, CPU ms/frame (stages exclusive; phases inclusive)")
    keys = sorted(
        {k for p in profiles.values() for k in p}, key=lambda k: (k.startswith("phase"), k == "total")
    )
    print("  " + f"{'stage':26s}" + "".join(f"{t:>20s}" for t in profiles))
    for k in keys:
        print("  " + f"{k:26s}" + "".join(f"{p.get(k, 0.0):20.2f}" for p in profiles.values()))

    def fps(tag: str, key: str, kind: str = "fps") -> float:
        return round(results[tag].get(key, {}).get(kind, float("nan")), 1)

    summary: dict[str, object] = {
        "normal_fps": fps("40x100", "normal"),
        "occlusion_fps": fps("40x100", "occlusion"),
        "opencv_csrt_fps": fps("40x100", "csrt"),
        "opencv_kcf_fps": fps("40x100", "kcf"),
        "opencv_kcf_gray_fps": fps("40x100", "kcf_gray"),
        "p95_ms_80x200": round(results["80x200"]["normal"]["p95_ms"], 2),
        "p95_ms_80x200_occlusion": round(results["80x200"]["occlusion"]["p95_ms"], 2),
        "dsst_fps": fps("40x100", "dsst"),
        "opencv_version": prim["version"],
        "siamese_v2_fps": round(siamese["siamese_v2"]["fps"], 1),
        "siamese_v3_fps": round(siamese["siamese_v3"]["fps"], 1),
        "opencv_nano_fps": round(siamese["opencv_nano"]["fps"], 1),
    }
    for tag in results:
        for key in names:
            if key in results[tag]:
                summary[f"{key}_fps_{tag}"] = fps(tag, key)
                summary[f"{key}_cpu_fps_{tag}"] = fps(tag, key, "cpu_fps")
                summary[f"{key}_p95_ms_{tag}"] = round(results[tag][key]["p95_ms"], 2)
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
