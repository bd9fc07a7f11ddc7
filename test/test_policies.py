# SPDX-License-Identifier: Apache-2.0
"""The long-term policies one by one (swir_tracker_ros/policies/), each on a real frame: the mechanism each
one is there for, through its own small surface (the whole tracker is pinned in test_tracker_*.py)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.windows import scale_windows, search_window
from swir_tracker_ros.policies.coast import CoastModel, CoastParams
from swir_tracker_ros.policies.lookalike import LookalikeGuard, LookalikeParams
from swir_tracker_ros.policies.memory import AppearanceMemory, MemoryParams
from swir_tracker_ros.policies.motion import MotionFilter, MotionParams
from swir_tracker_ros.policies.occlusion import OcclusionParams, OcclusionVerdict
from swir_tracker_ros.policies.redetection import Redetection, RedetectionParams
from swir_tracker_ros.policies.rejected import RejectedFrames, RejectedParams
from swir_tracker_ros.policies.scale_search import ScaleSearch, ScaleSearchParams
from swir_tracker_ros.policies.sweep import LongLossSweep, SweepParams
from swir_tracker_ros.policies.trail import Trail
from swir_tracker_ros.policies.update_gate import UpdateGate, UpdateGateParams
from swir_tracker_ros.tracker import TrackerParams
from swir_tracker_ros.types import Box, TrackState

SEQ = "otb_jogging-1"  # a jogger (25x101 px) on a path; frame 1 and frame 3


@pytest.fixture(scope="module")
def scene(sequences_dir: Path) -> tuple[np.ndarray, np.ndarray, Box, Box]:
    """Frames 1 and 3 of OTB jogging-1 (conditioned to [0, 1] float) and the jogger's boxes there."""
    seq = sequences_dir / SEQ
    imgs = [cv2.imread(str(seq / f"{k:06d}.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32) / 255.0
            for k in (1, 3)]
    gts = [Box(*map(float, line.split(","))) for line in (seq / "gt.txt").read_text().split()[:3]]
    return imgs[0], imgs[1], gts[0], gts[2]


def trained(img: np.ndarray, box: Box, memory: bool = False):
    """The default base filter trained on `box` of `img` (and its long-term memory started)."""
    base = make_filter(TrackerParams().base, box.w, box.h)
    base.initialise(img, box)
    if memory:
        base.start_memory()
    return base


def window(box: Box, base, dx: float = 0.0, dy: float = 0.0) -> Box:
    return search_window(box.cx + dx, box.cy + dy, box.w, box.h, base.padding)


def test_occlusion_verdict_fails_background_and_bars_weak_returns(scene) -> None:
    """The base filter's PSR test fails a window on background; after an occlusion a non-failed but weak
    peak is rejected (reacquire_peak_ratio); the verdict counts frames and turns `lost` after max_frames."""
    img, later, box, _ = scene
    base = trained(img, box)
    verdict = OcclusionVerdict(OcclusionParams(max_frames=2), base.failed, base.psr_reacquisition)
    on = base.detect(later, [window(box, base)])[0]
    off = base.detect(later, [window(box, base, dx=-4.0 * box.w)])[0]  # the path, far left of the jogger
    assert not verdict.failed(on) and verdict.failed(off), (on.psr, off.psr)
    assert not verdict.weak(0.01)  # no tracked frame yet: no mean to compare with
    verdict.tracked(on.peak)
    assert not verdict.rejects(on)  # not after an occlusion
    assert verdict.missed() is TrackState.OCCLUDED and verdict.occluded == 1
    assert verdict.rejects(replace(on, peak=0.5 * on.peak)) and not verdict.rejects(on)
    assert verdict.rejects(replace(on, psr=8.0))  # non-failed (>= 7) but under the re-acquisition PSR
    assert verdict.missed() is TrackState.OCCLUDED and verdict.missed() is TrackState.LOST
    papers = OcclusionVerdict(OcclusionParams(reacquire_peak_ratio=0.0, reacquire_psr=0.0), base.failed, True)
    papers.tracked(on.peak)
    papers.missed()
    assert not papers.rejects(replace(on, peak=0.1 * on.peak, psr=7.5))


def test_update_gate_freezes_refused_frames_until_a_lasting_change_teaches_at_a_fraction(scene) -> None:
    """LMCF's gate refuses a frame whose peak is below 0.7 x the mean; after `unconfident_after` refusals in
    a row a refused frame teaches at `unconfident_rate` of the learning rate; failed frames never."""
    img, later, box, _ = scene
    base = trained(img, box)
    gate = UpdateGate(UpdateGateParams(unconfident_rate=0.2, unconfident_after=2))
    det = base.detect(later, [window(box, base)])[0]
    assert gate.rate(base, det, rejected=True) is None
    assert gate.rate(base, det, rejected=False) == base.learning_rate  # sets the gate's means
    dim = replace(det, peak=0.3 * det.peak)
    assert gate.rate(base, dim, False) is None and gate.rate(base, dim, False) is None
    assert gate.rate(base, dim, False) == pytest.approx(0.2 * base.learning_rate)
    assert gate.rate(base, det, False) == base.learning_rate and gate.refused == 0
    frozen = UpdateGate(UpdateGateParams(unconfident_rate=0.0))
    frozen.rate(base, det, False)
    assert all(frozen.rate(base, dim, False) is None for _ in range(30))


def test_memory_knows_the_target_and_vetoes_background(scene) -> None:
    """The memory (the first-frame model) verifies the window that won: the jogger's passes and raises the
    mean; a window on the path is rejected and does not count."""
    img, later, box, _ = scene
    base = trained(img, box, memory=True)
    memory = AppearanceMemory(MemoryParams(ratio=0.5), base)
    base.detect(later, [window(box, base), window(box, base, dx=-4.0 * box.w)])
    assert memory.knows(1)  # no verified frame yet
    assert memory.verdict(0) == (False, True) and memory.peak_n == 1
    assert memory.knows(0) and not memory.knows(1)
    rejected, learn = memory.verdict(1)
    assert rejected and not learn and memory.peak_n == 1


def test_scale_search_adds_the_wide_sizes_only_while_redetecting(scene) -> None:
    img, _, box, _ = scene
    base = trained(img, box)
    search = ScaleSearch(ScaleSearchParams())
    assert search.factors(base, 0) == pytest.approx((0.9, 0.95, 1.0, 1.05, 1.1))
    assert search.factors(base, 3) == pytest.approx((1 / 1.2, 0.9, 0.95, 1.0, 1.05, 1.1, 1.2))
    assert ScaleSearch(ScaleSearchParams(redetect_scales=0.0)).factors(base, 3) == search.factors(base, 0)


def test_redetection_lattice_finds_the_target_the_grid_misses(scene) -> None:
    """A prediction a third of a window beside the jogger after a failed frame: the lattice (ours) finds
    him near his true centre; the papers' grid's windows sit a third of a window off him on both sides."""
    img, later, box, truth = scene
    base = trained(img, box)
    pred = box.shifted(box.w * (1.0 + base.padding) / 3.0, 0.0)
    normal = ScaleSearch(ScaleSearchParams(n=1)).search(base, later, pred, OcclusionVerdict(
        OcclusionParams(), base.failed, True))
    found = Redetection(RedetectionParams()).search(base, later, pred, normal, occluded=1)
    assert abs(found.det.cx - truth.cx) < 0.3 * box.w and len(found.windows) > 9
    grid = Redetection(RedetectionParams(lattice_step=0.0)).search(base, later, pred, normal, occluded=1)
    assert len(grid.windows) == 9 and found.det.peak > grid.det.peak


def test_long_loss_sweep_finds_a_target_far_from_the_prediction(scene) -> None:
    """After `after` frames of re-detection, each frame searches one tile of a raster over the image with
    the memory; the tile over the jogger, far from a prediction that walked off, gives a jump to him."""
    img, later, box, truth = scene
    base = trained(img, box, memory=True)
    memory = AppearanceMemory(MemoryParams(), base)
    base.detect(later, [window(box, base)])
    memory.verdict(0)
    verdict = OcclusionVerdict(OcclusionParams(), base.failed, True)
    verdict.tracked(base.detect(later, [window(box, base)])[0].peak)
    params = TrackerParams()
    sweep = LongLossSweep(SweepParams(after=3), params.redetection)
    pred = Box.from_center(img.shape[1] - box.w, box.cy, box.w, box.h)  # the far right edge
    at_pred = base.detect(later, [window(pred, base)])[0]
    verdict.missed()
    assert sweep.search(base, later, pred, window(pred, base), at_pred, verdict, memory,
                        ScaleSearch(params.scale)) is None  # 1 frame of re-detection: not yet
    verdict.missed(), verdict.missed()
    jumps = [sweep.search(base, later, pred, window(pred, base), at_pred, verdict, memory,
                          ScaleSearch(params.scale)) for _ in range(12)]
    found = [j for j in jumps if j is not None]
    assert found and abs(found[0].det.cx - truth.cx) < 0.3 * box.w and abs(found[0].det.cy - truth.cy) < 10


def test_lookalike_guard_takes_the_box_back_to_the_motion_reference(scene) -> None:
    """A tracked frame whose peak left where the trail's earlier motion puts the target (a look-alike took
    it): the window at the reference holds the target, passes the bars, and wins."""
    img, later, box, truth = scene
    base = trained(img, box)
    trail = Trail(50)
    for _ in range(30):  # the jogger's trail: standing where he is on `later`, 30 tracked frames
        trail.advance(1.0, 0.0, 0.0)
        trail.remember(truth)
    trail.advance(1.0, 0.0, 0.0)
    guard = LookalikeGuard(LookalikeParams(frames=12), trail)
    verdict = OcclusionVerdict(OcclusionParams(), base.failed, True)
    search = ScaleSearch(ScaleSearchParams(n=1))
    away = truth.shifted(-1.5 * box.w, 0.0)  # the box walked off with something else
    scales = search.search(base, later, away, verdict)
    verdict.tracked(base.detect(later, [window(truth, base)])[0].peak)
    takeback = guard.check(base, later, scales.dets[0], away, scales.wins, scales.factors, verdict)
    assert takeback is not None and takeback.velocity == (0.0, 0.0)
    back = takeback.dets[takeback.best]
    assert abs(back.cx - truth.cx) < 0.2 * box.w and guard.departed == 1
    guard.taken_back()
    assert guard.departed == 0 and len(trail.centres) == 30 - 11  # the frames after the reference dropped
    on = search.search(base, later, truth, verdict)
    assert guard.check(base, later, on.dets[0], truth, on.wins, on.factors, verdict) is None


def test_rejected_frames_keep_the_recent_sizes_and_stop_steering_after_a_while() -> None:
    trail = Trail(50)
    for s in (40.0, 44.0, 42.0):
        trail.advance(1.0, 0.0, 0.0)
        trail.remember(Box.from_center(100.0, 100.0, s, s))
    pred = Box.from_center(100.0, 100.0, 42.0, 42.0)
    policy = RejectedFrames(RejectedParams(after=25))
    assert policy.scale(pred, 1.2, trail) == pytest.approx(44.0 / 42.0)  # grows back, not beyond
    assert policy.scale(pred, 0.5, trail) == pytest.approx(40.0 / 42.0)
    assert policy.scale(pred, 1.01, trail) == pytest.approx(1.01)
    assert not policy.held(24, weak=False, index=0, memory=None)  # a short loss still steers
    assert policy.held(25, weak=False, index=0, memory=None)  # vetoed by the memory: held
    assert not policy.held(25, weak=True, index=0, memory=None)  # only weak, nobody says otherwise


def test_coast_model_holds_the_size_and_coasts_on_the_trail(scene) -> None:
    """A failed frame holds the size velocity; the first missed frame takes the trail's mean velocity
    over the whole window; `frames` stops the motion after that many frames of re-detection."""
    img, _, box, _ = scene
    base = trained(img, box)
    motion = MotionFilter(MotionParams(), base, box)
    trail = Trail(50)
    for k in range(10):  # 10 frames at 2 px/frame to the right
        trail.advance(1.0, 0.0, 0.0)
        trail.remember(box.shifted(2.0 * k, 0.0))
    motion.kf.x[motion.size_rates] = 0.3
    coast = CoastModel(CoastParams(frames=5, velocity_decay=0.5))
    coast.start(motion, trail)
    assert motion.velocity() == pytest.approx((18.0 / 50.0, 0.0))  # 18 px over the 50-frame window
    coast.redetecting(motion, occluded=1)
    assert np.all(motion.kf.x[motion.size_rates] == 0.0)
    assert motion.velocity() == pytest.approx((9.0 / 50.0, 0.0))
    coast.redetecting(motion, occluded=5)
    assert motion.velocity() == (0.0, 0.0)
    kalman = MotionFilter(MotionParams(), base, box)
    kalman.set_velocity(3.0, 1.0)
    CoastModel(CoastParams(trail_velocity=False)).start(kalman, trail)
    assert kalman.velocity() == (3.0, 1.0)


def test_trail_keeps_its_window_and_removes_ego_shifts() -> None:
    trail = Trail(5)
    for k in range(8):
        trail.advance(1.0, 1.0, 0.0)  # the image shifts 1 px right each frame
        trail.remember(Box.from_center(100.0 + k, 50.0, 10.0, 10.0))
    assert [c for c, _, _ in trail.centres] == [3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    assert {x for _, x, _ in trail.centres} == {99.0}  # moving with the image: standing in the world
    trail.forget_after(5.0)
    assert [c for c, _, _ in trail.centres] == [3.0, 4.0, 5.0]


def test_scale_windows_of_the_search_are_those_of_the_factors(scene) -> None:
    img, later, box, _ = scene
    base = trained(img, box)
    verdict = OcclusionVerdict(OcclusionParams(), base.failed, True)
    res = ScaleSearch(ScaleSearchParams(climb=False)).search(base, later, box, verdict)
    assert res.wins == scale_windows(box.cx, box.cy, box.w, box.h, base.padding, res.factors)
    assert res.mid == 2 and len(res.dets) == 5
