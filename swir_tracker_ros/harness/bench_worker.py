# SPDX-License-Identifier: Apache-2.0
"""Runs one OpenCV tracker (KCF, CSRT, MOSSE) over one source inside .venv-bench; prints JSON to stdout.

Started by `harness compare` as `.venv-bench/bin/python -m swir_tracker_ros.harness.bench_worker` with the
repository on PYTHONPATH; imports only numpy, cv2 (opencv-contrib), rosbags and this package's plain parts.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import cv2
import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.sources import open_source

FACTORIES = {
    "KCF": lambda: cv2.TrackerKCF_create(),
    "CSRT": lambda: cv2.TrackerCSRT_create(),
    "MOSSE": lambda: cv2.legacy.TrackerMOSSE_create(),
}


def to_bgr8(image: np.ndarray) -> np.ndarray:
    """OpenCV's trackers take 8-bit images: 16-bit frames get a 1-99 % percentile stretch per frame."""
    if image.dtype != np.uint8:
        lo, hi = np.percentile(image[::4, ::4], (1.0, 99.0))
        scale = 255.0 / max(float(hi - lo), 1.0)
        image = np.clip((image.astype(np.float32) - lo) * scale, 0, 255).astype(np.uint8)
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image


def run(spec: str, name: str, max_frames: int | None) -> dict:
    src = open_source(spec, max_frames=max_frames)
    trk = None
    pred, gt, occ = [], [], []
    seconds = 0.0
    for fr in src.frames():
        gt.append(None if fr.gt is None else list(fr.gt.as_tuple()))
        occ.append(fr.occluded)
        img = to_bgr8(fr.image)
        if trk is None:
            if fr.gt is None:
                pred.append(None)
                continue
            trk = FACTORIES[name]()
            t0 = time.perf_counter()
            trk.init(img, tuple(round(v) for v in fr.gt.as_tuple()))
            seconds += time.perf_counter() - t0
            pred.append(list(fr.gt.as_tuple()))
            continue
        t0 = time.perf_counter()
        ok, box = trk.update(img)
        seconds += time.perf_counter() - t0
        pred.append([float(v) for v in box] if ok else None)
    return {"name": src.name, "tracker": name, "pred": pred, "gt": gt, "occluded": occ, "seconds": seconds}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source")
    ap.add_argument("--tracker", choices=sorted(FACTORIES), required=True)
    ap.add_argument("--frames", type=int, default=None)
    args = ap.parse_args(argv)
    try:
        json.dump(run(args.source, args.tracker, args.frames), sys.stdout)
    except HarnessError as exc:
        print(f"bench_worker: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
