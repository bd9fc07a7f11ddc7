# SPDX-License-Identifier: Apache-2.0
"""Identity keeping on synthetic thermal scenes (paper 004 Fig. 6): a crossing and a 10-frame occlusion."""

from __future__ import annotations

import motmetrics as mm
import numpy as np
import pytest

from swir_tracker_ros.acquisition.detectors import MotionDetector
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker
from swir_tracker_ros.scene import crowd


def _identity_map(scene: crowd.CrowdScene, frames: int, tracker: MultiTargetTracker, detector=None,
                  seed: int = 0) -> tuple[dict[int, list[int]], int]:
    """Run a scene; MOT matching (motmetrics: keep a GT-track pair while IoU >= 0.5, else Hungarian).

    Returns, for every ground-truth id, the track ids matched to it frame by frame, and the number of ID
    switches motmetrics counts.
    """
    rng = np.random.default_rng(seed)
    acc = mm.MOTAccumulator(auto_id=True)
    for k in range(frames):
        img, gts = crowd.render(scene, k)
        dets = detector.detect(img) if detector is not None else crowd.simulated_detections(gts, rng)
        tracks = tracker.step(img, dets)
        gts = [g for g in gts if g.visible_fraction >= 0.25]
        dist = np.array([[1.0 - g.box.iou(t.box) for t in tracks] for g in gts])
        dist = dist.reshape(len(gts), len(tracks))
        dist[dist > 0.5] = np.nan
        acc.update([g.id for g in gts], [t.id for t in tracks], dist)
    ev = acc.mot_events
    seen: dict[int, list[int]] = {}
    for _, row in ev[ev["Type"].isin(["MATCH", "SWITCH"])].iterrows():
        seen.setdefault(int(row["OId"]), []).append(int(row["HId"]))
    switches = int((ev["Type"] == "SWITCH").sum())
    return seen, switches


def test_crowd_scenes_are_staged_in_image_columns_and_rendered_by_the_scene_world() -> None:
    cross = crowd.crossing_scene(3, frames=60)
    frame, truths = crowd.render(cross, 0)
    assert frame.dtype == np.uint8 and frame.shape == (480, 640)
    world_frame, world_truths = cross.world.render(0.0, crowd.VIEW)  # one renderer: the scene package's
    assert np.array_equal(frame, world_frame) and truths == world_truths
    assert [round(t.box.cx) for t in truths] == [70, 570]
    assert [round(t.box.cx) for t in crowd.render(cross, 60)[1]] == [570, 70]  # swapped after `frames`
    assert 100 < truths[1].box.h < truths[0].box.h < 130  # walker 2 walks 1 m behind walker 1
    meet = crowd.meeting_scene(3, frames=60)
    centres = [[t.box.cx for t in crowd.render(meet, k)[1]] for k in (0, 30, 60)]
    assert centres[1] == pytest.approx([312.0, 328.0], abs=1.0)  # they meet at frames // 2 ...
    assert centres[2] == pytest.approx(centres[0], abs=1.0)  # ... and walk back where they came from
    for n in (4, 10, 20):
        scene = crowd.occlusion_scene(2, occluded_frames=n)
        hidden = [k for k in range(90) if crowd.render(scene, k)[1][0].visible_fraction == 0.0]
        assert n <= len(hidden) <= n + 2 and hidden == list(range(hidden[0], hidden[0] + len(hidden)))
    empty = crowd.render(crowd.occlusion_scene(2, occluder=False, start_u=-30.0), 0)[1]
    assert empty == []  # the walker is still outside the image


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_two_pedestrians_crossing_keep_their_ids(seed: int) -> None:
    scene = crowd.crossing_scene(seed)
    hidden = min(g.visible_fraction for k in range(30, 50) for g in crowd.render(scene, k)[1])
    assert hidden < 0.3  # one really hides the other mid-way
    seen, switches = _identity_map(scene, 80, MultiTargetTracker(MotParams()), seed=seed)
    assert sorted(seen) == [1, 2]
    ids = {g: set(v) for g, v in seen.items()}
    assert switches == 0 and all(len(v) == 1 for v in ids.values()), ids
    assert ids[1] != ids[2]
    assert all(len(v) > 50 for v in seen.values())  # tracked before and after the crossing


def test_pedestrian_occluded_for_ten_frames_keeps_its_id() -> None:
    scene = crowd.occlusion_scene(0, occluded_frames=10)
    hidden = [k for k in range(80) if crowd.render(scene, k)[1][0].visible_fraction == 0.0]
    assert len(hidden) >= 10
    seen, switches = _identity_map(scene, 80, MultiTargetTracker(MotParams()))
    assert switches == 0 and set(seen[1]) == {seen[1][0]}
    assert len(seen[1]) > 40


@pytest.mark.xfail(strict=True, reason="regression (issue 16), still 0 of seeds 0-7 with this issue's "
                   "detector: going behind the pole its boxes shrink from the leading side by less than "
                   "partial_ratio, are measured in full and slow the track (4.0 -> 3.4 px/frame); ~20 frames "
                   "unseen later the prediction lags the walker by ~15 px, the emerging part is no one-sided "
                   "cut of it and fails the IoU gate (min_iou 0.3): a new ID. See docs/acquisition.md")
def test_occlusion_with_our_motion_detector_keeps_the_id() -> None:
    # Our motion detector sees the walker go behind the pole and come out piecewise: half a body, then an arm
    # or a leg first. Those partial boxes update only their visible edges (motion.visible_edges), so the
    # track keeps its size, position and velocity and the whole pedestrian falls inside its gate again.
    # Measured: the ID is kept for 7 of seeds 0-7 (seed 1 fails: the box narrows a little per frame on the
    # way in, each step within partial_ratio, and the slowed track misses the arm); before the partial
    # update it was kept for 1 of 8 (seed 5), which this threshold rejects.
    kept = []
    for seed in range(8):
        scene = crowd.occlusion_scene(seed, occluded_frames=10)
        seen, switches = _identity_map(scene, 80, MultiTargetTracker(MotParams()), MotionDetector())
        if switches == 0 and len(seen.get(1, [])) > 30 and len(set(seen[1])) == 1:
            kept.append(seed)
    assert len(kept) >= 6, kept
