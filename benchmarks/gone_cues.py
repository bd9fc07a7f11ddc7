# SPDX-License-Identifier: Apache-2.0
"""Dump the gone-verdict cues of the Siamese network alone, frame by frame, with their labels.

Plays `SiameseTracker` exactly as the harness's `network` player does (harness/runner.py `Player.siamese`,
harness/evaluate.py `run_starts`, OPE): init on the first frame with ground truth, with that box, `update` on
every later frame, its own state throughout. For every later frame it records the sequence, the video
(meta.json `video`, else the sequence name), the frame number (1-based), whether the target is absent
(gt `0,0,0,0`), the IoU of the network's box (`SiameseResult.box`, what OPE scores) with the truth (NaN when
absent), and the cues of policies/gone.py `cues` (one search, online), plus the log size change of the
regressed box over the searched size (a diagnostic). Written to one compressed npz (out/ is not committed):

    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/gone_cues.py --version v3
    OMP_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/gone_cues.py --version v2

The development set: every sequence folder (a folder with gt.txt) under each `--roots` (default the shared
24, ../shared/data/sequences, and the built corpus, ../corpus). Nothing of the data is copied anywhere but
out/.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.core.siamese.params import SiameseParams
from swir_tracker_ros.core.siamese.tracker import SiameseTracker
from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.sources import Source, open_source
from swir_tracker_ros.policies.gone import CUE_NAMES, cues

REPO = Path(__file__).resolve().parents[1]
ROOTS = (REPO.parent / "shared" / "data" / "sequences", REPO.parent / "corpus")


def sequence_dirs(roots: list[Path]) -> list[Path]:
    """Every folder with a gt.txt directly under each root, in name order per root."""
    return [d for root in roots for d in sorted(root.iterdir()) if d.is_dir() and (d / "gt.txt").exists()]


def play(path: Path, version: str) -> dict[str, list]:
    """One OPE pass of the network over a sequence folder: per frame after the start, cues and labels."""
    try:
        src = open_source(path)
    except HarnessError as exc:  # a meta.json key the harness checks (e.g. the shared 24's absent count)
        print(f"  {path.name}: {exc}; meta.json read as plain JSON", flush=True)
        meta = json.loads((path / "meta.json").read_text()) if (path / "meta.json").exists() else {}
        src = Source(path.name, "sequence", str(path), 25.0, 8, None, meta)
    video = str(src.meta.get("video") or src.name)
    trk: SiameseTracker | None = None
    rows: dict[str, list] = {k: [] for k in ("sequence", "video", "frame", "absent", "iou", "iou_box",
                                             "size_change", *CUE_NAMES)}
    for fr in src.frames():
        if trk is None:
            if fr.gt is None:
                continue
            trk = SiameseTracker(SiameseParams(version=version))
            trk.init(fr.image, fr.gt)
            continue
        w0, h0 = trk.size
        res = trk.update(fr.image)
        det = res.detection
        rows["sequence"].append(src.name)
        rows["video"].append(video)
        rows["frame"].append(fr.index + 1)
        rows["absent"].append(fr.gt is None)
        rows["iou"].append(math.nan if fr.gt is None else res.box.iou(fr.gt))
        rows["iou_box"].append(math.nan if fr.gt is None else det.box.iou(fr.gt))
        rows["size_change"].append(0.5 * math.log(max(det.box.w * det.box.h, 1e-9) / (w0 * h0)))
        for k, v in cues(det).as_dict().items():
            rows[k].append(v)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--version", default="v3", choices=("v2", "v3"))
    ap.add_argument("--roots", nargs="+", type=Path, default=list(ROOTS))
    ap.add_argument("--only", nargs="*", default=None, help="sequence names to play (default: all)")
    ap.add_argument("--out", type=Path, default=None, help="default out/gone/cues_<version>.npz")
    args = ap.parse_args(argv)
    cv2.setNumThreads(1)
    out = args.out or REPO / "out" / "gone" / f"cues_{args.version}.npz"
    out.parent.mkdir(parents=True, exist_ok=True)
    dirs = [d for d in sequence_dirs(args.roots) if not args.only or d.name in args.only]
    table: dict[str, list] = {}
    t0 = time.perf_counter()
    for k, d in enumerate(dirs, 1):
        t = time.perf_counter()
        rows = play(d, args.version)
        for key, vals in rows.items():
            table.setdefault(key, []).extend(vals)
        iou = np.array(rows["iou"], dtype=float)
        print(f"[{k:2d}/{len(dirs)}] {d.name:<32} {len(rows['frame']):5d} frames, absent "
              f"{sum(rows['absent']):3d}, IoU<0.1 {int(np.sum(iou < 0.1)):4d}, "
              f"{time.perf_counter() - t:5.1f} s", flush=True)
    arrays = {k: np.array(v, dtype=str if k in ("sequence", "video") else
                          bool if k == "absent" else int if k == "frame" else float)
              for k, v in table.items()}
    np.savez_compressed(out, version=np.array(args.version), **arrays)
    print(f"{len(arrays['frame'])} frames of {len(dirs)} sequences in {time.perf_counter() - t0:.0f} s "
          f"-> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
