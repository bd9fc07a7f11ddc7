# SPDX-License-Identifier: Apache-2.0
"""Identity keeping on synthetic thermal scenes (paper 004 Fig. 6 claim): crossing and a 10-frame occlusion."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.acquisition import crowd
from swir_tracker_ros.acquisition.detectors import MotionDetector
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker


def _identity_map(scene: crowd.CrowdScene, frames: int, tracker: MultiTargetTracker, detector=None,
                  seed: int = 0) -> dict[int, list[int]]:
    """For every ground-truth id, the sequence of track ids that covered it (IoU > 0.5), frame by frame."""
    rng = np.random.default_rng(seed)
    bg = crowd.background(scene)
    seen: dict[int, list[int]] = {}
    for k in range(frames):
        img, gts = crowd.render(scene, k, bg)
        dets = detector.detect(img) if detector is not None else crowd.simulated_detections(gts, rng)
        for t in tracker.step(img, dets):
            best = max(gts, key=lambda g: g.box.iou(t.box))
            if best.box.iou(t.box) > 0.5:
                seen.setdefault(best.id, []).append(t.id)
    return seen


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_pedestrians_crossing_keep_their_ids(seed: int) -> None:
    scene = crowd.crossing_scene(seed)
    _, gts = crowd.render(scene, 40)
    assert min(g.visibility for g in gts) < 0.2  # they really overlap mid-way
    seen = _identity_map(scene, 80, MultiTargetTracker(MotParams()), seed=seed)
    assert sorted(seen) == [1, 2]
    ids = {g: set(v) for g, v in seen.items()}
    assert all(len(v) == 1 for v in ids.values()), ids  # no identity switch
    assert ids[1] != ids[2]
    assert all(len(v) > 50 for v in seen.values())  # tracked before and after the crossing


def test_pedestrian_occluded_for_ten_frames_keeps_its_id() -> None:
    scene = crowd.occlusion_scene(0, occluded_frames=10)
    bg = crowd.background(scene)
    hidden = [k for k in range(80) if crowd.render(scene, k, bg)[1][0].visibility == 0.0]
    assert len(hidden) >= 10
    seen = _identity_map(scene, 80, MultiTargetTracker(MotParams()))
    assert set(seen[1]) == {seen[1][0]}
    assert len(seen[1]) > 40


def test_occlusion_with_our_motion_detector_keeps_the_id() -> None:
    scene = crowd.occlusion_scene(1, occluded_frames=10)
    seen = _identity_map(scene, 80, MultiTargetTracker(MotParams()), MotionDetector())
    assert len(seen[1]) > 30 and len(set(seen[1])) == 1
