# SPDX-License-Identifier: Apache-2.0
"""Runs one OpenCV tracker (KCF, CSRT, MOSSE, Nano) over one source inside .venv-bench; prints JSON to stdout.

Started by `harness compare` as `.venv-bench/bin/python -m swir_tracker_ros.harness.bench_worker` with the
repository on PYTHONPATH; imports only numpy, cv2 (opencv-contrib), rosbags and this package's plain parts.

One process runs several starts of the same tracker side by side over one decoding of the frames: the OPE
start (`none`, the ground-truth box of the first frame with ground truth) and any SRE perturbations
(`--perturb left scale_0.8 ...`, boxes from `metrics.sre_box`), or one explicit start box (`--init`).
`Nano` (OpenCV's TrackerNano, NanoTrack through the DNN module) needs its two ONNX files, `--backbone` and
`--neckhead` (the harness passes the pinned v2 files that core/siamese/locator.py finds).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import cv2
import numpy as np

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.metrics import SRE_PERTURBATIONS, SRE_STYLES, sre_box
from swir_tracker_ros.harness.sources import open_source
from swir_tracker_ros.types import Box


def _nano(models: dict[str, str]) -> object:
    """OpenCV's TrackerNano on the given backbone and neck-head ONNX files."""
    if not models.get("backbone") or not models.get("neckhead"):
        raise HarnessError("the Nano tracker needs --backbone and --neckhead (NanoTrack ONNX files)")
    params = cv2.TrackerNano_Params()
    params.backbone, params.neckhead = models["backbone"], models["neckhead"]
    return cv2.TrackerNano_create(params)


FACTORIES = {
    "KCF": lambda: cv2.TrackerKCF_create(),
    "CSRT": lambda: cv2.TrackerCSRT_create(),
    "MOSSE": lambda: cv2.legacy.TrackerMOSSE_create(),
}
MODEL_FACTORIES = {"Nano": _nano}  # trackers built from model files (tracker name -> constructor(models))
WORKER_VERSION = 3  # part of the peer-cache key: bump when a change here changes the boxes


def to_bgr8(image: np.ndarray) -> np.ndarray:
    """OpenCV's trackers take 8-bit images: 16-bit frames get a 1-99 % percentile stretch per frame."""
    if image.dtype != np.uint8:
        lo, hi = np.percentile(image[::4, ::4], (1.0, 99.0))
        scale = 255.0 / max(float(hi - lo), 1.0)
        image = np.clip((image.astype(np.float32) - lo) * scale, 0, 255).astype(np.uint8)
    return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR) if image.ndim == 2 else image


def cv_rect(box: Box) -> tuple[int, int, int, int]:
    """OpenCV's init takes an integer rectangle: round the corners, keep at least 1 px."""
    x0, y0 = round(box.x), round(box.y)
    x1, y1 = round(box.x + box.w), round(box.y + box.h)
    return x0, y0, max(1, x1 - x0), max(1, y1 - y0)


def run(spec: str, name: str, max_frames: int | None, perturbations: list[str] | None = None,
        init: Box | None = None, style: str = "otb", models: dict[str, str] | None = None) -> dict:
    """Every start's per-frame boxes and ok flags, the shared ground truth, occlusion flags and shares;
    `models`: the ONNX files of a tracker that needs them (Nano: backbone, neckhead)."""
    src = open_source(spec, max_frames=max_frames)
    starts = ["init"] if init is not None else (perturbations or ["none"])
    trackers: dict[str, object] = {}
    runs = {p: {"perturbation": p, "init": None, "pred": [], "ok": [], "seconds": 0.0} for p in starts}
    gt, occ, share = [], [], []
    for fr in src.frames():
        gt.append(None if fr.gt is None else list(fr.gt.as_tuple()))
        occ.append(fr.occluded)
        share.append(getattr(fr, "occlusion", None))
        img = to_bgr8(fr.image)
        if not trackers:
            if fr.gt is None:
                for r in runs.values():
                    r["pred"].append(None)
                    r["ok"].append(False)
                continue
            h, w = img.shape[:2]
            for p, r in runs.items():
                box = init if init is not None else sre_box(fr.gt, p, w, h, style)
                trk = MODEL_FACTORIES[name](models or {}) if name in MODEL_FACTORIES else FACTORIES[name]()
                t0 = time.perf_counter()
                trk.init(img, cv_rect(box))
                r["seconds"] += time.perf_counter() - t0
                r["init"] = list(box.as_tuple())
                r["pred"].append(list(box.as_tuple()))
                r["ok"].append(False)  # the start frame is no tracking claim
                trackers[p] = trk
            continue
        for p, trk in trackers.items():
            r = runs[p]
            t0 = time.perf_counter()
            ok, box = trk.update(img)
            r["seconds"] += time.perf_counter() - t0
            # a failed update (ok False) shows the last box the tracker gave, as an application would and as
            # our tracker reports its box in every state; `ok` False is no tracking claim (false tracking)
            r["pred"].append([float(v) for v in box] if ok else r["pred"][-1])
            r["ok"].append(bool(ok))
    if not trackers:
        raise HarnessError(f"{src.name}: no frame with ground truth; nothing to track")
    return {"name": src.name, "tracker": name, "opencv": cv2.__version__, "worker": WORKER_VERSION,
            "gt": gt, "occluded": occ, "occlusion": share, "runs": list(runs.values())}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source")
    ap.add_argument("--tracker", choices=sorted((*FACTORIES, *MODEL_FACTORIES)), required=True)
    ap.add_argument("--frames", type=int, default=None)
    ap.add_argument("--perturb", nargs="+", default=None, choices=("none", *SRE_PERTURBATIONS),
                    help="starts to run side by side (none = the ground-truth box; default: none)")
    ap.add_argument("--style", choices=SRE_STYLES, default="otb", help="SRE box definition (metrics.sre_box)")
    ap.add_argument("--init", default=None, metavar="X,Y,W,H", help="one explicit start box instead")
    ap.add_argument("--backbone", default=None, help="Nano: the backbone ONNX file")
    ap.add_argument("--neckhead", default=None, help="Nano: the neck-head ONNX file")
    args = ap.parse_args(argv)
    try:
        init = None
        if args.init is not None:
            try:
                init = Box(*(float(v) for v in args.init.split(",")))
            except (TypeError, ValueError):
                raise HarnessError(f"--init wants X,Y,W,H, got {args.init!r}") from None
        models = {"backbone": args.backbone, "neckhead": args.neckhead}
        json.dump(run(args.source, args.tracker, args.frames, args.perturb, init, args.style, models),
                  sys.stdout)
    except HarnessError as exc:
        print(f"bench_worker: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
