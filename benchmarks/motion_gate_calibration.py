# SPDX-License-Identifier: Apache-2.0
"""Calibrate the motion gate of a network-led track (policies/lead.py `LeadParams.jump_gate`) on stored runs.

Reads only storage (`harness` results): the OPE runs of a tracker that follows the network's every answer
(default `siamese_v3`, the network alone) on the development set, and the ground truth. On each sequence it
replays the lead's Kalman filter (configs/lead.py's MotionParams, `MotionFilter`) on the run's boxes, as the
lead does on its accepted frames, and takes each frame's motion cue: the distance of the box's centre from the
prediction over the last box's size (`policies.lead.off_path`). Labels (present frames only):

- `left`: the box left the target on this frame (IoU with the truth < 0.1 where it was >= 0.3 on the frame
  before): what the gate must catch;
- `kept`: IoU >= 0.5 on this frame and the one before: what the gate must let through.

For each gate: the recall of `left` frames, their precision among the frames gated, and the share of `kept`
frames gated (mean over videos, the windows of a video pooled: the OPE cost proxy), also per data folder (the
UAV and handheld clips of the corpus show the camera's own motion). The ego shift is unknown in these runs
(as in `harness eval`), so camera motion counts as target motion: the gate must not fire on it.

    .venv/bin/python benchmarks/motion_gate_calibration.py --label siamese_v3
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections import defaultdict
from types import SimpleNamespace

import numpy as np

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.harness.commands import DEFAULT_RESULTS
from swir_tracker_ros.harness.devset import DEV, catalogue, data_dirs
from swir_tracker_ros.harness.store import RunStore
from swir_tracker_ros.kalman.adaptive import PAPER000_KCF
from swir_tracker_ros.kalman.models import kcf_box_model
from swir_tracker_ros.policies.lead import off_path
from swir_tracker_ros.policies.motion import MotionFilter
from swir_tracker_ros.types import Box

GATES = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0)
LEFT_FROM, LEFT_TO, KEPT = 0.3, 0.1, 0.5


def cues(boxes: list[Box | None], gt: list[Box | None]) -> list[tuple[float, str]]:
    """(motion cue, label) of every frame 2..N of one run whose label is `left` or `kept` (module docstring);
    the Kalman filter is updated with every box (the network alone accepts every answer)."""
    p = configuration("lead").motion
    assert p is not None
    base = SimpleNamespace(box_model=lambda w, h: kcf_box_model(), threshold_map=PAPER000_KCF,
                           robust_method="A4")
    first = boxes[0]
    if first is None or not first.is_valid():
        return []
    motion = MotionFilter(p, base, first)  # type: ignore[arg-type]
    last, prev_iou, out = first, 1.0, []
    for box, truth in zip(boxes[1:], gt[1:]):
        pred = motion.predict(1.0, 0.0, 0.0)
        if box is None or not box.is_valid():
            prev_iou = 0.0
            continue
        d = off_path(box, pred, math.sqrt(last.w * last.h))
        iou = box.iou(truth) if truth is not None else None
        if iou is not None:
            if iou < LEFT_TO and prev_iou >= LEFT_FROM:
                out.append((d, "left"))
            elif iou >= KEPT and prev_iou >= KEPT:
                out.append((d, "kept"))
        prev_iou = iou if iou is not None else 0.0
        motion.update(motion.measurement(box.cx, box.cy, box.w, box.h), motion.threshold(1.0))
        last = box
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="siamese_v3", help="stored runs to replay (default: siamese_v3)")
    ap.add_argument("--data", nargs="+", default=None, metavar="DIR", help=f"data folders (default {DEV})")
    ap.add_argument("--results", default=None, help=f"results directory (default {DEFAULT_RESULTS})")
    a = ap.parse_args(argv)
    infos = catalogue(data_dirs(a.data or [DEV]))
    store = RunStore(a.results or os.environ.get("SWIR_RESULTS") or DEFAULT_RESULTS)
    per_video: dict[str, list[tuple[float, str]]] = defaultdict(list)
    group: dict[str, str] = {}
    for name, info in sorted(infos.items()):
        rec, truth = store.load(a.label, name, "none", None), store.load_truth(name)
        if rec is None or truth is None:
            continue
        per_video[info.video] += cues(rec.boxes, truth.gt)
        group[info.video] = info.group
    if not per_video:
        print(f"motion_gate_calibration: no stored runs of {a.label} in {store.root}", file=sys.stderr)
        return 2
    left = np.array([d for v in per_video.values() for d, lab in v if lab == "left"])
    kept_n = sum(1 for v in per_video.values() for _, lab in v if lab == "kept")
    print(f"{a.label}: {len(per_video)} videos, {len(left)} `left` frames, {kept_n} `kept` frames")
    groups = sorted(set(group.values()))
    print("| gate (target sizes) | recall of left | precision | kept gated (mean over videos) | "
          + " | ".join(f"kept gated, {g}" for g in groups) + " |")
    print("|---" * (4 + len(groups)) + "|")
    for g in GATES:
        caught = int(np.sum(left > g))
        gated = sum(1 for v in per_video.values() for d, lab in v if d > g)
        rates = {vid: np.mean([d > g for d, lab in v if lab == "kept"])
                 for vid, v in per_video.items() if any(lab == "kept" for _, lab in v)}
        by_group = [np.mean([r for vid, r in rates.items() if group[vid] == gr] or [0.0]) for gr in groups]
        print(f"| {g:.2f} | {caught / max(len(left), 1):.3f} | {caught / max(gated, 1):.3f} | "
              f"{np.mean(list(rates.values())):.4f} | " + " | ".join(f"{r:.4f}" for r in by_group) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
