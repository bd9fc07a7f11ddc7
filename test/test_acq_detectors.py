# SPDX-License-Identifier: Apache-2.0
"""Detectors: background subtraction (with head-motion compensation), OpenCV HOG on real frames, det.txt."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.acquisition.detectors import (
    HogPeopleDetector,
    MotDetFile,
    MotionDetector,
    MotionParams,
    greedy_matches,
)
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.scene import crowd
from swir_tracker_ros.types import Box


def test_motion_detector_finds_walkers_and_ignores_the_static_scene() -> None:
    scene = crowd.occlusion_scene(3, occluder=False)
    det = MotionDetector()
    hits = []
    for k in range(30):
        img, gts = crowd.render(scene, k)
        boxes = [d.box for d in det.detect(img)]
        if k >= 10:
            hits.append(max((b.iou(gts[0].box) for b in boxes), default=0.0))
            assert len(boxes) <= 2
    assert np.mean(np.array(hits) > 0.5) > 0.9
    static = MotionDetector()
    img, _ = crowd.render(crowd.CrowdScene(seed=4), 0)
    assert all(static.detect(img) == [] for _ in range(15))


def _tud_recall_precision(seq: Path, det: MotionDetector) -> tuple[float, float]:
    """Per frame, greedy one-to-one matching at IoU >= 0.5 against the ground truth (all 71 frames, warm-up
    included): (matched / ground truth, matched / detections)."""
    rows = np.loadtxt(seq / "gt.txt", delimiter=",", ndmin=2)
    tp = n_det = n_gt = 0
    for f in range(1, int(rows[:, 0].max()) + 1):
        img = cv2.imread(str(seq / f"{f:06d}.png"), cv2.IMREAD_GRAYSCALE)
        gt = [Box(r[2] - 1.0, r[3] - 1.0, r[4], r[5]) for r in rows[rows[:, 0] == f]]
        boxes = [d.box for d in det.detect(img)]
        used_b, _ = greedy_matches(boxes, gt)
        tp += len(used_b)
        n_det += len(boxes)
        n_gt += len(gt)
    return tp / n_gt, tp / n_det


def test_motion_detector_finds_most_pedestrians_on_tud_campus(shared_dir: Path) -> None:
    # Static camera, people present from the first frame and walking in groups. The former running Gaussian
    # background found 4 % at 6 % precision, the temporal median with person-width splitting 47.9 % at
    # 51.8 %; with the ghost test, the head split, a 1-frame warm-up and the closing scaled with the people
    # found 54.3 % at 67.9 %; with the people partly behind a nearer one found in the columns left over
    # (bands) it measures 63.8 % at 63.1 % (benchmarks/motion_eval.py; a fifth of the ground truth is more
    # than half hidden behind nearer people, most of them with their head inside the nearer silhouette).
    seq = shared_dir / "data" / "mot" / "tud_campus"
    recall, precision = _tud_recall_precision(seq, MotionDetector())
    assert recall > 0.62 and precision > 0.61, (recall, precision)  # issue 16: both >= 60 %
    # Each change carries its share: without the bands 54.3 % at 67.9 %; without the head split (and so
    # without bands) groups stay one box or are cut at the wrong columns (51.5 % at 59.9 %); without the
    # ghost test the places people left are reported (54.5 % precision).
    no_bands = _tud_recall_precision(seq, MotionDetector(MotionParams(band_min_h=0.0)))
    no_heads = _tud_recall_precision(seq, MotionDetector(MotionParams(head_prominence=1e9)))
    no_ghost = _tud_recall_precision(seq, MotionDetector(MotionParams(ghost_speed=0.0)))
    assert no_bands[0] < recall - 0.08, no_bands
    assert no_heads[0] < recall - 0.1 and no_heads[1] < precision, no_heads
    assert no_ghost[1] < precision - 0.03, no_ghost


def _textured_background(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    b = cv2.GaussianBlur(rng.uniform(0, 255, (480, 640)).astype(np.float32), (0, 0), 6.0)
    return np.clip((b - b.mean()) * 4 + 120, 0, 255)


def test_ghost_of_someone_who_stood_still_is_absorbed() -> None:
    # A person stands at column 100 for 16 frames, then walks off at 6 px per frame. The median buffer holds
    # them at the old place for about as long again: once the walker's region has left it (frame 27), a
    # region there without motion is a ghost, written into the background and not reported (Cucchiara et
    # al. 2003); the walker himself is still found.
    bg = _textured_background(1)
    kept, ghost = MotionDetector(), MotionDetector(MotionParams(ghost_speed=0.0))
    stray = {id(kept): 0, id(ghost): 0}
    found = 0
    for k in range(40):
        img = bg.copy()
        x = 100 if k < 16 else 100 + 6 * (k - 15)
        cv2.rectangle(img, (x - 30, 226), (x + 30, 360), 40.0, -1)
        cv2.circle(img, (x, 213), 13, 40.0, -1)
        truth = Box(x - 30.0, 200.0, 60.0, 160.0)
        frame = img.astype(np.uint8)
        for det in (kept, ghost):
            boxes = [d.box for d in det.detect(frame)]
            if k >= 27:
                stray[id(det)] += sum(b.iou(truth) < 0.1 and abs(b.cx - 100) < 40 for b in boxes)
                if det is kept:
                    found += any(b.iou(truth) > 0.5 for b in boxes)
    assert stray[id(kept)] == 0
    assert stray[id(ghost)] >= 4  # without the test the ghost stays until the median forgets it
    assert found >= 12


def test_person_partly_behind_a_nearer_one_is_found() -> None:
    # A near walker (feet at row 360) and a farther one (feet at 340, 100 px tall) walk together, the far
    # one's right third behind the near one and his head hidden: one foreground region, one head on its
    # outline. The columns left of the near walker's box, whose pixels end above his feet, are the far one
    # (`_bands`); without them the region is one box.
    bg = _textured_background(2)
    found = {True: 0, False: 0}
    dets = {True: MotionDetector(), False: MotionDetector(MotionParams(band_min_h=0.0))}
    for k in range(30):
        img = bg.copy()
        x = 100 + 12 * k
        cv2.rectangle(img, (x - 25, 226), (x + 25, 360), 40.0, -1)
        cv2.circle(img, (x, 213), 12, 40.0, -1)
        cv2.rectangle(img, (x - 49, 240), (x - 13, 340), 60.0, -1)
        near, far = Box(x - 25.0, 201.0, 50.0, 160.0), Box(x - 49.0, 240.0, 36.0, 100.0)
        for bands, det in dets.items():
            boxes = [d.box for d in det.detect(img.astype(np.uint8))]
            if k >= 12:  # the median buffer has forgotten where they started
                found[bands] += any(b.iou(far) > 0.5 for b in boxes) and any(b.iou(near) > 0.5 for b in boxes)
    assert found[True] >= 15, found
    assert found[False] == 0, found


def _pan(img: np.ndarray, dx: float) -> np.ndarray:
    M = np.array([[1.0, 0.0, dx], [0.0, 1.0, 0.0]], np.float32)
    return cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), borderMode=cv2.BORDER_REFLECT)


def test_known_image_shift_is_compensated() -> None:
    rng = np.random.default_rng(0)
    base = cv2.GaussianBlur(rng.uniform(0, 255, (240, 320)).astype(np.float32), (0, 0), 2.0)
    base = np.clip(base * 3 - 250, 0, 255).astype(np.uint8)  # strong texture: a shift shows up everywhere
    with_comp, without = MotionDetector(), MotionDetector()
    n_with = n_without = 0
    for k in range(20):
        frame = _pan(base, 2.0 * k)
        shift = (2.0, 0.0) if k else (0.0, 0.0)
        n_with += len(with_comp.detect(frame, shift))
        n_without += len(without.detect(frame))
    assert n_with == 0
    assert n_without > 10


def test_hog_people_detector_on_tud_campus(shared_dir: Path) -> None:
    seq = shared_dir / "data" / "mot" / "tud_campus"
    rows = np.loadtxt(seq / "gt.txt", delimiter=",")
    hog = HogPeopleDetector()
    matched = total = 0
    for f in (10, 30, 50):
        img = cv2.imread(str(seq / f"{f:06d}.png"), cv2.IMREAD_GRAYSCALE)
        gt = [Box(r[2] - 1, r[3] - 1, r[4], r[5]) for r in rows[rows[:, 0] == f]]
        dets = hog.detect(img)
        assert dets and all(0.0 < d.score < 1.0 for d in dets)
        matched += sum(max(d.box.iou(g) for d in dets) > 0.5 for g in gt)
        total += len(gt)
    assert matched >= total // 3, (matched, total)


def test_det_file_replays_mot_detections(shared_dir: Path, tmp_path: Path) -> None:
    det = MotDetFile(shared_dir / "data" / "mot" / "tud_campus" / "det.txt")
    first = det.detect(np.zeros((4, 4), np.uint8))
    assert first[0].box == Box(197.0, 202.0, 62.22, 141.19)  # 1-based MOT box made 0-based
    assert 0.0 < first[0].score <= 1.0
    with pytest.raises(AcquisitionError):
        MotDetFile(tmp_path / "missing.txt")
