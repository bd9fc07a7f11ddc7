# SPDX-License-Identifier: Apache-2.0
"""Cost of the acquisition's detectors per call at 640x512 on one thread, and of acquisition at 10 Hz.

The frames are TUD-Campus's (../shared/data/mot/tud_campus) resized to 640x512, as mono8 and as mono16
(x 64 + 0..63 noise: a 14-bit SWIR range); every detector sees the same frames in turn within each round
(the same machine load for all). Prints one markdown table (docs/acquisition.md, "Speed"): the median and
90th percentile milliseconds of one `detect` call, then the association (`MultiTargetTracker.step`,
Siamese on) on the learned detector's boxes and the share of one core that detection + association take at
10 Hz.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/detector_speed.py [--frames 40] [--rounds 3]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # OpenCV / BLAS: one thread, as the detectors' runtime

import cv2
import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from swir_tracker_ros.acquisition.detectors import HogPeopleDetector, MotionDetector  # noqa: E402
from swir_tracker_ros.acquisition.learned import YoloxDetector, model_problem  # noqa: E402
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker  # noqa: E402

TUD = REPO.parent / "shared" / "data" / "mot" / "tud_campus"
SIZE = (640, 512)


def frames(n: int) -> list[np.ndarray]:
    files = sorted(TUD.glob("*.png"))[:n]
    if not files:
        raise SystemExit(f"no frames in {TUD}")
    return [cv2.resize(cv2.imread(str(f), cv2.IMREAD_GRAYSCALE), SIZE, interpolation=cv2.INTER_AREA)
            for f in files]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args(argv)
    cv2.setNumThreads(1)
    f8 = frames(a.frames)
    rng = np.random.default_rng(0)
    f16 = [(f.astype(np.uint16) * 64 + rng.integers(0, 64, f.shape)).astype(np.uint16) for f in f8]
    dets: dict[str, object] = {"motion (mono8)": MotionDetector(), "hog (mono8)": HogPeopleDetector()}
    problem = model_problem()
    if problem is None:
        dets = {"yolox (mono8)": YoloxDetector(), "yolox (mono16)": YoloxDetector(), **dets}
    else:
        print(f"# learned detector skipped: {problem}", file=sys.stderr)
    times: dict[str, list[float]] = {k: [] for k in dets}
    boxes = []
    for r in range(a.rounds):
        for name, d in dets.items():
            d.reset()
            src = f16 if "mono16" in name else f8
            for f in src:
                t0 = time.perf_counter()
                out = d.detect(f)
                times[name].append(time.perf_counter() - t0)
                if r == 0 and name == "yolox (mono8)":
                    boxes.append(out)
    print(f"### Detectors at {SIZE[0]}x{SIZE[1]}, one thread ({a.frames} frames x {a.rounds} rounds)\n")
    print("| detector | median ms per call | p90 ms | calls per second |\n|---|---|---|---|")
    for name, t in times.items():
        ms = 1000 * np.array(t)
        print(f"| {name} | {np.median(ms):.1f} | {np.percentile(ms, 90):.1f} | {1000 / np.median(ms):.0f} |")
    if boxes:
        mot = MultiTargetTracker(MotParams())
        assoc = []
        for f, b in zip(f8, boxes, strict=True):
            t0 = time.perf_counter()
            mot.step(f, b)
            assoc.append(time.perf_counter() - t0)
        det_ms = float(np.median(1000 * np.array(times["yolox (mono8)"])))
        as_ms = float(np.median(1000 * np.array(assoc)))
        share = 10.0 * (det_ms + as_ms) / 1000.0  # 10 calls a second
        print(f"\nassociation (MultiTargetTracker.step, Siamese on) on the learned boxes: median {as_ms:.1f} "
              f"ms per frame ({np.mean([len(b) for b in boxes]):.1f} boxes); detection + association at "
              f"10 Hz: {100 * share:.0f}% of one core")
    return 0


if __name__ == "__main__":
    sys.exit(main())
