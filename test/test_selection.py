# SPDX-License-Identifier: Apache-2.0
"""Stamped selection without ROS: the frame history's bounds, finding a frame by stamp, the checks that
reject a selection, a click turned into a box (synthetic and real frames), and the catch-up."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from test_tracker_node_unit import TW, scene

from swir_tracker_ros.nodes.point_box import box_around_point
from swir_tracker_ros.nodes.selection import (
    CatchUp,
    Code,
    FrameHistory,
    SelectionRules,
    StoredFrame,
    Verdict,
    start_box,
)
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box, TrackState


def stored(stamp: float, pixels: np.ndarray, elapsed: float = 1.0) -> StoredFrame:
    return StoredFrame(stamp, pixels, 16 if pixels.dtype == np.uint16 else None, elapsed)


def test_history_is_bounded_by_age_and_memory() -> None:
    frame = np.zeros((10, 10), np.uint16)  # 200 bytes
    hist = FrameHistory(max_age_s=1.0, max_bytes=10_000)
    for k in range(30):
        hist.add(stored(100.0 + 0.1 * k, frame))
    assert [round(f.stamp, 1) for f in hist.frames] == [round(101.9 + 0.1 * k, 1) for k in range(11)]
    small = FrameHistory(max_age_s=60.0, max_bytes=1000)
    for k in range(30):
        small.add(stored(100.0 + 0.1 * k, frame))
    assert len(small) == 5 and small.nbytes == 1000
    none = FrameHistory(max_age_s=0.0, max_bytes=0)  # the newest frame is always kept
    none.add(stored(1.0, frame))
    none.add(stored(2.0, frame))
    assert len(none) == 1 and none.frames[0].stamp == 2.0


def test_find_by_stamp_and_the_reasons_it_gives() -> None:
    hist = FrameHistory(max_age_s=1.0, max_bytes=1 << 30)
    verdict = hist.find(5.0, 0.1)
    assert isinstance(verdict, Verdict) and verdict.code is Code.NO_FRAME
    assert "no frame received" in verdict.reason
    for k in range(11):
        hist.add(stored(10.0 + 0.1 * k, np.zeros((4, 4), np.uint8)))
    assert hist.find(10.3, 0.01).stamp == pytest.approx(10.3)
    assert hist.find(10.33, 0.05).stamp == pytest.approx(10.3)  # the nearest stored frame
    assert hist.find(0.0, 0.05).stamp == pytest.approx(11.0)  # no stamp: the newest frame
    old = hist.find(8.0, 0.05)
    assert old.code is Code.STAMP_TOO_OLD and "3.000 s before the newest" in old.reason
    assert hist.find(12.0, 0.05).code is Code.NO_FRAME
    assert hist.after(10.45).stamp == pytest.approx(10.5) and hist.after(11.0) is None


def test_start_box_checks() -> None:
    frame = stored(1.0, scene(100, 90))
    rules = SelectionRules(min_size=4.0, click_box_size=32.0)
    assert start_box(frame, Box(88, 78, 24, 24), None, rules) == Box(88, 78, 24, 24)
    outside = start_box(frame, Box(500, 10, 24, 24), None, rules)
    assert outside.code is Code.OUTSIDE_IMAGE and "240x192" in outside.reason
    tiny = start_box(frame, Box(50, 50, 3, 30), None, rules)
    assert tiny.code is Code.TOO_SMALL and "select_min_size 4" in tiny.reason
    assert start_box(frame, None, (240.0, 10.0), rules).code is Code.OUTSIDE_IMAGE
    clicked = start_box(frame, None, (101.0, 92.0), rules)
    assert isinstance(clicked, Box) and clicked.iou(Box.from_center(100, 90, TW, TW)) > 0.6


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_a_click_on_a_target_that_stands_out_finds_its_extent(dtype) -> None:
    rng = np.random.default_rng(1)
    img = 3000.0 + rng.normal(0, 30, (120, 160))
    img[40:90, 70:86] += 2500.0  # a standing pedestrian: 16 x 50 px, brighter than the background
    img = img if dtype == np.uint16 else img / 20.0
    found = box_around_point(img.astype(dtype), 77.0, 60.0, default_size=32.0)
    assert found.segmented and found.box.iou(Box(70, 40, 16, 50)) > 0.8, found
    dark = box_around_point((8000.0 - img).astype(np.float32), 77.0, 60.0)  # polarity does not matter
    assert dark.segmented and dark.box.iou(Box(70, 40, 16, 50)) > 0.8
    flat = box_around_point(np.full((120, 160), 50, np.uint8), 20.0, 30.0, default_size=24.0)
    assert not flat.segmented and flat.box == Box(8.0, 18.0, 24.0, 24.0)  # nothing there: the default
    corner = box_around_point(np.full((120, 160), 50, np.uint8), 2.0, 3.0, default_size=24.0)
    assert corner.box.x == 0.0 and corner.box.y == 0.0  # clipped to the image
    with pytest.raises(ValueError, match="outside"):
        box_around_point(img, 160.0, 3.0)


def _sequence_clicks(root: Path, names: tuple[str, ...]) -> list[tuple[float, float]]:
    """(IoU of the click box, IoU of the default square) with the ground truth, clicking near the centre
    of the target (within 15 % of its size) on 10 frames spread over each sequence."""
    rng = np.random.default_rng(0)
    out = []
    for name in names:
        seq = root / name
        gts = [tuple(map(float, line.split(",")[:4])) for line in (seq / "gt.txt").read_text().split()]
        frames = sorted([*seq.glob("*.png"), *seq.glob("*.jpg")])
        for k in range(0, len(frames), max(1, len(frames) // 10)):
            gt = Box(*gts[k])
            img = cv2.imread(str(frames[k]), cv2.IMREAD_UNCHANGED)
            x, y = gt.cx + rng.uniform(-0.15, 0.15) * gt.w, gt.cy + rng.uniform(-0.15, 0.15) * gt.h
            found = box_around_point(img, x, y, default_size=32.0)
            out.append((found.box.iou(gt), Box.from_center(x, y, 32.0, 32.0).iou(gt)))
    return out


THERMAL = ("antiuav_irclip04", "antiuav_irclip07", "antiuav_irclip40", "ptbtir_airplane")


def test_click_boxes_on_real_frames(sequences_dir: Path) -> None:
    """On real thermal frames the object under the click stands out and its box fits it better than the
    default square does; over every sequence (visible clutter included) it is no worse on average."""
    thermal = np.array(_sequence_clicks(sequences_dir, THERMAL))
    assert thermal[:, 0].mean() > thermal[:, 1].mean() + 0.1, thermal.mean(axis=0)
    names = tuple(sorted(p.name for p in sequences_dir.iterdir() if (p / "gt.txt").is_file()))
    every = np.array(_sequence_clicks(sequences_dir, names))
    assert len(every) > 150 and every[:, 0].mean() >= every[:, 1].mean(), every.mean(axis=0)


def _pose_shift(fx: float):
    """Ego shift from a head panning left by 0.004 rad per 0.04 s frame (the scene moves right)."""
    def shift(t0: float, t1: float, _w: int, _h: int) -> tuple[float, float]:
        return fx * math.tan(0.1 * (t1 - t0)), 0.0
    return shift


def test_catch_up_tracks_the_stored_frames_with_their_ego_shifts() -> None:
    hist = FrameHistory(max_age_s=5.0, max_bytes=1 << 30)
    fx = 600.0
    # The target walks right by 2 px a frame; the head pans left, so the whole scene also moves right by
    # fx * tan(0.004) = 2.4 px a frame: a target at 4.4 px a frame in the image.
    path = [(60.0 + 4.4 * k, 96.0) for k in range(25)]
    for k, (cx, cy) in enumerate(path):
        hist.add(stored(10.0 + 0.04 * k, scene(cx, cy, seed=k)))
    start = hist.find(10.0 + 0.04 * 5, 0.01)
    calls: list[tuple[float, float]] = []

    def spy(t0: float, t1: float, w: int, h: int) -> tuple[float, float]:
        calls.append((round(t0, 2), round(t1, 2)))
        return _pose_shift(fx)(t0, t1, w, h)

    job = CatchUp(Tracker(TrackerParams()), start, Box.from_center(*path[5], TW, TW), hist, spy)
    steps = 0
    while not job.step():
        steps += 1
    assert job.verdict.accepted and job.frames_done == 19 and steps == 19
    # one ego shift per stored frame, between it and the frame before (the head poses of those stamps)
    assert calls == [(round(10.2 + 0.04 * k, 2), round(10.24 + 0.04 * k, 2)) for k in range(19)]
    assert job.verdict.stamp == pytest.approx(10.2) and job.verdict.box == Box.from_center(*path[5], TW, TW)
    assert job.result.state is TrackState.TRACKING and job.frame.stamp == pytest.approx(10.96)
    assert job.result.box.center_distance(Box.from_center(*path[-1], TW, TW)) < 3.0
    # Frames that arrive while catching up are tracked too before it is done.
    hist.add(stored(11.0, scene(60.0 + 4.4 * 25, 96.0, seed=25), elapsed=1.0))
    job2 = CatchUp(Tracker(TrackerParams()), start, Box.from_center(*path[5], TW, TW), hist, _pose_shift(fx))
    for _ in range(10):
        job2.step()
    hist.add(stored(11.04, scene(60.0 + 4.4 * 26, 96.0, seed=26)))
    while not job2.step():
        pass
    assert job2.frame.stamp == pytest.approx(11.04) and job2.frames_done == 21


def test_catch_up_failures_are_verdicts() -> None:
    hist = FrameHistory(max_age_s=5.0, max_bytes=1 << 30)
    hist.add(stored(1.0, scene(100, 90)))
    bad = CatchUp(Tracker(TrackerParams()), hist.frames[0], Box(0, 0, 0.5, 0.5), hist, _pose_shift(1.0))
    assert bad.done and bad.verdict.code is Code.TRACKER_FAILED and "cannot start" in bad.verdict.reason
    hist.add(stored(1.04, scene(100, 90).astype(np.uint8)))
    job = CatchUp(Tracker(TrackerParams()), hist.frames[0], Box(88, 78, 24, 24), hist, _pose_shift(1.0))
    assert job.step() and job.verdict.code is Code.TRACKER_FAILED and "format" in job.verdict.reason
