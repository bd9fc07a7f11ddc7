# SPDX-License-Identifier: Apache-2.0
"""Which inference runtime runs the Siamese networks: OpenCV's DNN module or onnxruntime (CPU), per model.

For every model the project ships (NanoTrack v2, v3, LightTrack-M; core/siamese/params.py VERSIONS; and the
acquisition's five embedding nets, one embedding of 8 patches in the "search" column), on real
crops (a frame of a shared sequence, the exemplar and the search crop cut as the tracker cuts them), with 1
and 2 threads, the two runtimes timed in turn within each repeat (the same load for both on a shared
machine): the median milliseconds of one exemplar pass (backbone on the exemplar crop) and of one search
(backbone on the search crop + head), and the largest difference of each runtime's search outputs from
onnxruntime's (score map and side distances, relative to the output's largest value when above 1; "wrong"
when the backbone's features have another shape, as cv2.dnn's for LightTrack-M's). Prints one table
(docs/siamese.md, "One runtime"); then each version's whole tracker (`SiameseTracker`, onnxruntime, one
thread) stepped in turn on the same frames (--tracker-frames of --tracker-sequence; otb_walking2, as the
LightTrack reference's speed figure).

    .venv/bin/python benchmarks/runtime_speed.py [--repeats 60] [--threads 1 2] [--sequence otb_crossing]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.core.siamese.crops import blob, context_side, cut_subpixel
from swir_tracker_ros.core.siamese.locator import locate
from swir_tracker_ros.core.siamese.maps import softmax_score
from swir_tracker_ros.core.siamese.network import bgr_batch, session
from swir_tracker_ros.core.siamese.params import VERSIONS, VersionConstants
from swir_tracker_ros.errors import ModelError
from swir_tracker_ros.harness.sources import frame_files, read_frame, read_gt

SEQUENCES = Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "sequences"
Pass = Callable[[np.ndarray], np.ndarray]


def crops(c: VersionConstants, sequence: Path) -> tuple[np.ndarray, np.ndarray]:
    """(exemplar, search) uint8 crops: frame 1's box as the exemplar, frame 11 searched around it."""
    files, gt = frame_files(sequence), read_gt(sequence)
    b = gt[0]
    s_z = context_side(b.w, b.h, 0.5)
    first = read_frame(files[0])
    fill = np.mean(first, axis=(0, 1))
    z = cut_subpixel(first, b.cx, b.cy, s_z, c.exemplar_size, fill)
    x = cut_subpixel(read_frame(files[10]), b.cx, b.cy, s_z * c.instance_size / c.exemplar_size,
                     c.instance_size, fill)
    return z, x


def onnxruntime_net(c: VersionConstants, threads: int) -> tuple[Pass, Callable]:
    """(backbone(crop) -> features, search(z_features, crop) -> (score, loc)) in onnxruntime."""
    nano = c.family == "nanotrack"
    bb = session(locate(c.backbone), threads, free_spatial=nano)
    head = session(locate(c.head), threads)
    name = bb.get_inputs()[0].name

    def backbone(crop: np.ndarray) -> np.ndarray:
        return bb.run(None, {name: blob(crop) if nano else bgr_batch(crop)})[0]

    def search(z: np.ndarray, crop: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = backbone(crop)
        if nano:
            cls, loc = head.run(None, {"input1": z, "input2": x})
            return softmax_score(cls[0]), loc[0]
        cls, reg = head.run(None, {"zf": z, "xf": x})
        return cls.reshape(cls.shape[-2:]), reg.reshape(4, *reg.shape[-2:])
    return backbone, search


def opencv_net(c: VersionConstants, threads: int) -> tuple[Pass, Callable]:
    """The same two passes in OpenCV's DNN module (what the project used before issue 45)."""
    cv2.setNumThreads(threads)
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)  # the wrong backbone's shape log
    nano = c.family == "nanotrack"
    bb = cv2.dnn.readNetFromONNX(str(locate(c.backbone)))
    head = cv2.dnn.readNetFromONNX(str(locate(c.head)))

    def backbone(crop: np.ndarray) -> np.ndarray:
        bb.setInput(blob(crop) if nano else bgr_batch(crop))
        return bb.forward().copy()

    def search(z: np.ndarray, crop: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = backbone(crop)
        head.setInput(z, "input1" if nano else "zf")
        head.setInput(x, "input2" if nano else "xf")
        cls, loc = head.forward(["output1", "output2"] if nano else ["cls", "reg"])
        if nano:
            return softmax_score(cls[0]), loc[0]
        return cls.reshape(cls.shape[-2:]), loc.reshape(4, *loc.shape[-2:])
    return backbone, search


def interleaved_ms(fns: list[Callable[[], object]], repeats: int) -> list[float]:
    """Median milliseconds of each of `fns`, timed in turn within every repeat (both runtimes see the same
    load on a shared machine), after 3 warm-up rounds."""
    for _ in range(3):
        for fn in fns:
            fn()
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(repeats):
        for fn, t in zip(fns, times):
            t0 = time.perf_counter()
            fn()
            t.append(time.perf_counter() - t0)
    return [1000.0 * statistics.median(t) for t in times]


def measure(version: str, threads: int, repeats: int, sequence: Path) -> dict[str, tuple[str, str, str]]:
    """Per runtime: (exemplar ms, search ms, max |diff| from onnxruntime's outputs) as table cells. A runtime
    whose backbone gives features of the wrong shape gets its backbone timed alone and "wrong" in the last
    cell."""
    c = VERSIONS[version]
    z_crop, x_crop = crops(c, sequence)
    nets = {"onnxruntime": onnxruntime_net(c, threads), "cv2.dnn": opencv_net(c, threads)}
    ref_b, ref_s = nets["onnxruntime"]
    ref_z, ref_x = ref_b(z_crop), ref_b(x_crop)
    ref_out = ref_s(ref_z, x_crop)
    exemplar, search, diffs = [], [], {}
    for name, (backbone, run) in nets.items():
        z, x = backbone(z_crop), backbone(x_crop)
        exemplar.append(lambda backbone=backbone: backbone(z_crop))
        if z.shape != ref_z.shape or x.shape != ref_x.shape:
            search.append(lambda backbone=backbone: backbone(x_crop))
            diffs[name] = (f"wrong: features {'x'.join(map(str, x.shape))} for the {x_crop.shape[0]} px crop "
                           f"(onnxruntime: {'x'.join(map(str, ref_x.shape))})")
            continue
        out = run(z, x_crop)
        rel = max(float(np.abs(a - b).max() / max(1.0, float(np.abs(b).max()))) for a, b in zip(out, ref_out))
        diffs[name] = f"{rel:.1e}"
        search.append(lambda run=run, z=z: run(z, x_crop))
    ex_ms, se_ms = interleaved_ms(exemplar, repeats), interleaved_ms(search, repeats)
    out = {}
    for k, name in enumerate(nets):
        only = " (backbone only)" if diffs[name].startswith("wrong") else ""
        out[name] = (f"{ex_ms[k]:.2f}", f"{se_ms[k]:.2f}{only}", diffs[name])
    return out


def acquisition_speed(repeats: int, sequence: Path) -> tuple[str, str, str, str]:
    """The acquisition's five embedding nets (paper 004; acquisition/siamese.py) on 8 real patches: ms per
    embedding of the 8 in each runtime (one pass of the 5 nets), and cv2.dnn's largest relative difference."""
    from swir_tracker_ros.acquisition.siamese import MODELS_DIR, NET_NAMES, SiameseFamily, crop_resized

    files, gt = frame_files(sequence), read_gt(sequence)
    frame = read_frame(files[0])
    patches = [crop_resized(frame, gt[0].shifted(dx, dy), 64) for dx in (-6, 0, 6) for dy in (-4, 4)][:6]
    patches += [crop_resized(frame, gt[0], 64), crop_resized(frame, gt[0].scaled(1.2), 64)]
    ours = SiameseFamily(MODELS_DIR)  # onnxruntime, one thread (acquisition/siamese.py)
    cv2.setNumThreads(1)
    dnn = [cv2.dnn.readNetFromONNX(str(MODELS_DIR / f"siamese_{n}.onnx")) for n in NET_NAMES]

    def opencv_embed() -> tuple[np.ndarray, np.ndarray]:
        saved = ours.nets
        try:
            ours.nets = [_DnnSession(n) for n in dnn]
            return ours.embed_patches(patches)
        finally:
            ours.nets = saved

    ref, alt = ours.embed_patches(patches), opencv_embed()
    rel = max(float(np.abs(a - b).max() / max(1.0, float(np.abs(b).max()))) for a, b in zip(alt, ref))
    ms = interleaved_ms([lambda: ours.embed_patches(patches), opencv_embed], repeats)
    return f"{ms[0]:.2f}", f"{ms[1]:.2f}", f"{rel:.1e}", str(len(patches))


class _DnnSession:
    """A cv2.dnn net behind onnxruntime's `run` / `get_inputs` (the acquisition nets in the old runtime)."""

    def __init__(self, net: cv2.dnn.Net) -> None:
        self.net = net

    def get_inputs(self) -> list:
        return [type("Input", (), {"name": ""})()]

    def run(self, _outputs: object, feeds: dict) -> list[np.ndarray]:
        self.net.setInput(next(iter(feeds.values())))
        return [self.net.forward()]


def tracker_speed(versions: list[str], sequence: Path, frames: int) -> None:
    """Whole-tracker speed (crops, network, decoding) of each version, the trackers stepped in turn on the
    same frames (the same load for all): median and mean ms per frame, one onnxruntime thread."""
    from swir_tracker_ros.core.siamese.params import SiameseParams
    from swir_tracker_ros.core.siamese.tracker import SiameseTracker

    files, gt = frame_files(sequence), read_gt(sequence)
    images = [read_frame(f) for f in files[:frames]]
    trackers = {v: SiameseTracker(SiameseParams(version=v)) for v in versions}
    times: dict[str, list[float]] = {v: [] for v in versions}
    for trk in trackers.values():
        trk.init(images[0], gt[0])
    for img in images[1:]:
        for v, trk in trackers.items():
            t0 = time.perf_counter()
            trk.update(img)
            times[v].append(time.perf_counter() - t0)
    print(f"\n# whole tracker, {len(images) - 1} frames of {sequence.name} ({images[0].shape[1]}x"
          f"{images[0].shape[0]}), trackers in turn; load average {os.getloadavg()[0]:.1f}")
    print("| version | search crop | median ms / frame | mean ms / frame | frames / s (median) |")
    print("|---|---|---|---|---|")
    for v, t in times.items():
        med = 1000.0 * statistics.median(t)
        print(f"| {v} | {trackers[v].instance_size} | {med:.1f} | {1000.0 * statistics.mean(t):.1f} | "
              f"{1000.0 / med:.0f} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=60, help="timed passes per cell (median)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--versions", nargs="+", default=list(VERSIONS))
    ap.add_argument("--sequence", default="otb_crossing", help=f"a sequence folder of {SEQUENCES}")
    ap.add_argument("--tracker-frames", type=int, default=150,
                    help="frames of the whole-tracker comparison (0: none)")
    ap.add_argument("--tracker-sequence", default="otb_walking2", help="its sequence")
    a = ap.parse_args(argv)
    seq = Path(a.sequence) if Path(a.sequence).is_dir() else SEQUENCES / a.sequence
    print(f"# {a.repeats} timed passes per cell (median), crops of {seq.name}; load average "
          f"{os.getloadavg()[0]:.1f}; cv2 {cv2.__version__}, onnxruntime "
          f"{__import__('onnxruntime').__version__}")
    print("| model | runtime | threads | exemplar ms | search ms | search outputs vs onnxruntime (max rel.) "
          "|")
    print("|---|---|---|---|---|---|")
    try:
        for version in a.versions:
            for threads in a.threads:
                for runtime, cells in measure(version, threads, a.repeats, seq).items():
                    print(f"| {version} | {runtime} | {threads} | {' | '.join(cells)} |", flush=True)
        ort_ms, dnn_ms, rel, n = acquisition_speed(a.repeats, seq)
        print(f"| acquisition (5 nets, {n} patches) | onnxruntime | 1 | - | {ort_ms} | 0.0e+00 |")
        print(f"| acquisition (5 nets, {n} patches) | cv2.dnn | 1 | - | {dnn_ms} | {rel} |", flush=True)
        if a.tracker_frames:
            ts = Path(a.tracker_sequence)
            tracker_speed(a.versions, ts if ts.is_dir() else SEQUENCES / ts, a.tracker_frames)
    except ModelError as exc:
        print(f"runtime_speed: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
