# SPDX-License-Identifier: Apache-2.0
"""Motion and size handling of the default variant: coasting through a long loss, the scale penalty."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackState


def _background(h: int, w: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.random((h, w)).astype(np.float32), (0, 0), 3.0)
    return 0.3 + 0.2 * (img - img.min()) / (img.max() - img.min())


def _frame(bg: np.ndarray, cx: float | None, cy: float) -> np.ndarray:
    """8-bit frame: `bg` plus a bright 16x32 figure with a dark stripe centred at (cx, cy) (None: hidden)."""
    img = bg.copy()
    if cx is not None:
        x0, y0 = round(cx) - 8, round(cy) - 16
        img[y0 : y0 + 32, x0 : x0 + 16] = 0.9
        img[y0 + 10 : y0 + 14, x0 : x0 + 16] = 0.15
    return (img * 255).astype(np.uint8)


def _moved_after_loss(coast: int) -> float:
    """A figure walks right at 3 px/frame for 40 frames, then vanishes for 60 frames: how far the box
    moves on from where it was when the figure vanished."""
    bg = _background(240, 480, 5)
    trk = Tracker(TrackerParams(coast_frames=coast))
    trk.init(_frame(bg, 60.0, 120.0), Box(52.0, 104.0, 16.0, 32.0))
    for k in range(1, 40):
        res = trk.update(_frame(bg, 60.0 + 3.0 * k, 120.0))
        assert res.state is TrackState.TRACKING
    lost_at = res.box.cx
    for _ in range(60):
        res = trk.update(_frame(bg, None, 120.0))
    assert res.state is not TrackState.TRACKING
    return res.box.cx - lost_at


def test_the_prediction_stops_after_coast_frames_of_loss() -> None:
    """With the papers' constant-velocity coast the prediction walks on into empty background (measured:
    53 px, until background peaks at the prediction hold it); with `coast_frames` 8 the centre velocity
    is dropped after 8 frames of re-detection and the search stays near where the figure was lost."""
    free, held = _moved_after_loss(0), _moved_after_loss(8)
    assert held < 3.0 * 8 + 8.0 and held < free - 15.0, (free, held)


def _track_sequence(seq_dir: Path, params: TrackerParams, n: int) -> tuple[list[Box], list[Box]]:
    """(boxes, ground truth) of frames 2..n of a real sequence tracked from frame 1's box."""
    pngs = sorted(seq_dir.glob("*.png"))[:n]
    gts = [Box(*(float(v) for v in line.split(",")[:4]))
           for line in (seq_dir / "gt.txt").read_text().split()]
    trk, boxes = Tracker(params), []
    for k, png in enumerate(pngs):
        img = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
        if k == 0:
            trk.init(img, gts[0])
        else:
            boxes.append(trk.update(img).box)
    return boxes, gts[1:n]


def test_scale_penalty_keeps_the_box_from_growing_onto_the_surroundings(sequences_dir: Path) -> None:
    """PTB-TIR airplane (thermal pedestrian, constant size ~40x118 px): with the paper's largest-peak
    scale pick the box creeps up in size (measured: 74x181 px at frame 241, 99x243 px at the end) because
    a larger window that takes in more of the warm surroundings scores a slightly higher peak every few
    frames; the KCFcpp scale weight 0.95 on the non-unit scales slows that down (58x143 px at frame 241)."""
    def growth(penalty: float) -> float:
        p = TrackerParams(scale_penalty=penalty)
        p.kcf.feature = "hog_gray"
        boxes, gts = _track_sequence(sequences_dir / "ptbtir_airplane", p, 250)
        return float(np.mean([b.h / g.h for b, g in zip(boxes[-50:], gts[-50:])]))

    free, weighted = growth(1.0), growth(0.95)
    assert free > 1.35 and weighted < 1.25, (free, weighted)
