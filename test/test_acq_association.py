# SPDX-License-Identifier: Apache-2.0
"""Gated cost matrix, Hungarian assignment and the track life cycle of paper 004 Section 3.1."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.acquisition.association import FORBIDDEN, CostWeights, Detection, assign, cost_matrix
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker, TrackStatus
from swir_tracker_ros.acquisition.motion import (
    ALL_EDGES,
    BOTTOM,
    LEFT,
    RIGHT,
    TOP,
    box_model,
    edge_model,
    gate_threshold,
    measurement,
    state_from_box,
    visible_edges,
)
from swir_tracker_ros.kalman.standard import update
from swir_tracker_ros.types import Box

FRAME = np.full((240, 320), 60, np.uint8)


def _frame_with(boxes: list[Box]) -> np.ndarray:
    img = FRAME.copy()
    for k, b in enumerate(boxes):
        img[int(b.y):int(b.y + b.h), int(b.x):int(b.x + b.w)] = 150 + 30 * k
    return img


def _tracker(**kw) -> MultiTargetTracker:
    return MultiTargetTracker(MotParams(use_siamese=False, **kw))


def test_hungarian_minimises_total_cost_and_rejects_forbidden() -> None:
    C = np.array([[1.0, 2.0], [1.5, 10.0]])
    matches, ur, uc = assign(C, max_cost=100.0)
    assert sorted(matches) == [(0, 1), (1, 0)]  # 2 + 1.5 < 1 + 10
    C = np.array([[FORBIDDEN, 3.0], [FORBIDDEN, FORBIDDEN]])
    matches, ur, uc = assign(C, max_cost=1e12)
    assert matches == [(0, 1)] and ur == [1] and uc == [0]
    matches, ur, uc = assign(np.array([[5.0]]), max_cost=4.0)
    assert matches == [] and ur == [0] and uc == [0]
    assert assign(np.zeros((0, 3)), 1.0) == ([], [], [0, 1, 2])


def test_gate_forbids_far_detections() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    trk.step(_frame_with([box]), [Detection(box)])
    near, far = box.shifted(3, 0), box.shifted(150, 0)
    dets = trk.describe(_frame_with([near]), [Detection(near), Detection(far)])
    C = cost_matrix(trk.tracks, dets, CostWeights())
    assert C[0, 0] < FORBIDDEN and C[0, 1] == FORBIDDEN


def test_tentative_track_is_confirmed_after_five_more_hits() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    shown = []
    for k in range(8):
        b = box.shifted(2 * k, 0)
        shown.append(len(trk.step(_frame_with([b]), [Detection(b)])))
    assert shown == [0, 0, 0, 0, 0, 1, 1, 1]  # birth + 5 hits -> displayed on the 6th frame
    assert trk.tracks[0].status is TrackStatus.CONFIRMED and trk.tracks[0].id == 1


def test_tentative_track_is_deleted_after_five_misses() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    trk.step(_frame_with([box]), [Detection(box)])
    for _ in range(4):
        trk.step(FRAME, [])
    assert len(trk.tracks) == 1
    trk.step(FRAME, [])
    assert trk.tracks == []


def test_confirmed_track_drifts_after_20_misses_and_dies_15_later() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    for _ in range(6):
        trk.step(_frame_with([box]), [Detection(box)])
    t = trk.tracks[0]
    assert t.status is TrackStatus.CONFIRMED
    for k in range(1, 36):
        trk.step(FRAME, [])
        if k < 20:
            assert t.status is TrackStatus.CONFIRMED
        elif k < 35:
            assert t.status is TrackStatus.DRIFTING and trk.tracks == [t]
    assert trk.tracks == []


def test_drifting_track_reassociated_keeps_its_id() -> None:
    trk = _tracker(gate_chi2=1e4)
    box = Box(100, 80, 30, 80)
    for _ in range(6):
        trk.step(_frame_with([box]), [Detection(box)])
    for _ in range(22):
        trk.step(FRAME, [])
    assert trk.tracks[0].status is TrackStatus.DRIFTING
    out = trk.step(_frame_with([box]), [Detection(box)])
    assert [t.id for t in out] == [1] and out[0].status is TrackStatus.CONFIRMED


def test_invalid_parameters_are_rejected() -> None:
    from swir_tracker_ros.errors import ParameterError

    with pytest.raises(ParameterError, match="gate_chi2"):
        MultiTargetTracker(MotParams(use_siamese=False, gate_chi2=-1.0))


def test_gate_threshold_keeps_the_confidence_of_the_centre_gate() -> None:
    assert gate_threshold(9.21, 2) == 9.21
    assert gate_threshold(9.21, 1) == pytest.approx(6.63, abs=0.01)  # chi^2_1(0.99)
    assert gate_threshold(9.21, 3) == pytest.approx(11.34, abs=0.01)  # chi^2_3(0.99)


def test_all_four_edges_measure_the_same_as_the_box() -> None:
    box, seen = Box(100, 80, 30, 80), Box(104, 83, 26, 84)
    _, _, H, R = box_model(1.0, 4.0, 6.4, 8.0)
    x, P = state_from_box(box), np.diag([40.0, 40.0, 60.0, 60.0, 9.0, 9.0])
    x_box, P_box = update(x, P, measurement(seen), R, H)
    z, He, Re = edge_model(H, R, seen, ALL_EDGES)
    x_edge, P_edge = update(x, P, z, Re, He)
    assert np.allclose(x_box, x_edge) and np.allclose(P_box, P_edge)
    z, He, Re = edge_model(H, R, seen, (LEFT,))
    assert z.tolist() == [104.0] and He.shape == (1, 6) and Re[0, 0] == pytest.approx(6.4**2 + 8.0**2 / 4)


def test_visible_edges_tell_occlusion_from_scale_change_and_fragments() -> None:
    pred, tol = Box(100, 100, 40, 100), (5.0, 5.0, 5.0, 5.0)

    def edges(det: Box) -> tuple[int, ...]:
        return visible_edges(pred, det, 0.75, 0.5, tol)

    assert edges(Box(103, 101, 38, 99)) == ALL_EDGES  # a full view
    assert edges(Box(90, 90, 60, 130)) == ALL_EDGES  # larger: a track may always grow
    assert edges(Box(101, 100, 18, 100)) == (LEFT, TOP, BOTTOM)  # walking behind a pole on its right
    assert edges(Box(121, 100, 19, 100)) == (TOP, RIGHT, BOTTOM)  # coming out on the pole's right
    assert edges(Box(100, 100, 40, 60)) == (LEFT, TOP, RIGHT)  # legs hidden by a wall
    assert edges(Box(111, 100, 18, 100)) == ALL_EDGES  # shrunk on both sides: a change of scale
    assert edges(Box(180, 100, 18, 100)) == ALL_EDGES  # far edge outside the predicted box: not this track's
    assert edges(Box(133, 140, 8, 25)) == (RIGHT,)  # an arm out on the right, mid-height: a fragment
    assert edges(Box(133, 230, 8, 25)) == ALL_EDGES  # a fragment below the predicted box
    assert visible_edges(pred, Box(101, 100, 18, 100), 0.0, 0.5, tol) == ALL_EDGES  # 0 = off (the paper)


def _walk(trk: MultiTargetTracker, boxes: list[Box], cut: int = 0) -> None:
    """Step boxes (one per frame); the last `cut` are seen with their right part hidden (width 12)."""
    for k, b in enumerate(boxes):
        seen = Box(b.x, b.y, 12, b.h) if k >= len(boxes) - cut else b
        trk.step(_frame_with([seen]), [Detection(seen)])


def test_a_pedestrian_cut_by_an_occluder_keeps_its_size_and_position() -> None:
    walk = [Box(60 + 3 * k, 80, 30, 80) for k in range(16)]  # 3 px per frame to the right
    occluded, paper = _tracker(), _tracker(partial_ratio=0.0)
    for trk in (occluded, paper):
        _walk(trk, walk[:12])
        assert trk.tracks[0].status is TrackStatus.CONFIRMED
    template = occluded.tracks[0].appearance
    _walk(occluded, walk[12:], cut=4)
    _walk(paper, walk[12:], cut=4)
    t, p = occluded.tracks[0], paper.tracks[0]
    assert t.partial_run == 4 and t.appearance is template  # edges only; the full view stays the template
    assert t.box.w > 27 and abs(t.box.cx - walk[-1].cx) < 3 and abs(t.x[4] - 3.0) < 0.6
    assert p.box.w < 20 and p.box.cx < walk[-1].cx - 6  # the paper's full update shrinks and drags the box


def test_a_lasting_change_of_size_is_measured_in_full_after_partial_max_run() -> None:
    walk = [Box(60 + 3 * k, 80, 30, 80) for k in range(20)]
    trk = _tracker(partial_max_run=5)
    _walk(trk, walk[:12])
    _walk(trk, walk[12:17], cut=5)
    assert trk.tracks[0].partial_run == 5 and trk.tracks[0].box.w > 27
    _walk(trk, walk[17:], cut=3)
    assert trk.tracks[0].partial_run == 0 and trk.tracks[0].box.w < 22  # the narrow box is the target now


def test_the_iou_gate_rejects_a_box_of_another_scale_inside_the_centre_gate() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    trk.step(_frame_with([box]), [Detection(box)])
    same, big = box.shifted(2, 0), Box.from_center(box.cx + 2, box.cy, 75, 200)  # same centre, 2.5x the size
    dets = trk.describe(_frame_with([same]), [Detection(same), Detection(big)])
    gated = cost_matrix(trk.tracks, dets, trk.weights)
    assert gated[0, 0] < FORBIDDEN and gated[0, 1] == FORBIDDEN
    loose = cost_matrix(trk.tracks, dets, CostWeights(min_iou=0.0, use_siamese=False))
    assert loose[0, 1] < FORBIDDEN  # the Mahalanobis gate on the centre alone lets it through


def test_a_partial_view_must_lie_inside_the_prediction() -> None:
    trk = _tracker()
    box = Box(100, 80, 30, 80)
    for _ in range(3):
        trk.step(_frame_with([box]), [Detection(box)])
    upper_inside = Box(100, 80, 30, 40)  # top half of the predicted box: an occluder hides the legs
    upper_offset = Box(112, 80, 30, 40)  # the same cut, but 40 % of it outside the prediction
    dets = trk.describe(_frame_with([box]), [Detection(upper_inside), Detection(upper_offset)])
    C = cost_matrix(trk.tracks, dets, trk.weights)
    assert C[0, 0] < FORBIDDEN and C[0, 1] == FORBIDDEN


def test_miss_counts_are_frames_at_25_hz_scaled_to_the_frame_rate() -> None:
    """At 1 Hz a confirmed track drifts after 1 miss (20 frames of 25 Hz = 0.8 s) and dies after 2; a
    tentative track dies after its first miss; at 50 Hz the counts double."""
    assert MotParams(frame_rate=50.0).frames(20) == 40 and MotParams(frame_rate=1.0).frames(15) == 1
    trk = _tracker(frame_rate=1.0, confirm_hits=1)
    box = Box(100, 80, 30, 80)
    for _ in range(2):
        trk.step(_frame_with([box]), [Detection(box)])
    t = trk.tracks[0]
    assert t.status is TrackStatus.CONFIRMED
    trk.step(_frame_with([box.shifted(200, 0)]), [Detection(box.shifted(200, 0))])  # a new, tentative one
    assert t.status is TrackStatus.DRIFTING and len(trk.tracks) == 2
    trk.step(FRAME, [])
    assert trk.tracks == []


def test_weak_detections_continue_tracks_but_start_none() -> None:
    """start_score: a detection scoring below it starts no track, yet continues a confirmed one (with
    high_score, in the second stage)."""
    trk = _tracker(start_score=0.7, high_score=0.6, confirm_hits=1)
    box = Box(100, 80, 30, 80)
    assert trk.step(_frame_with([box]), [Detection(box, 0.65)]) == [] and trk.tracks == []
    for _ in range(2):
        trk.step(_frame_with([box]), [Detection(box, 0.9)])
    out = trk.step(_frame_with([box]), [Detection(box, 0.3)])
    assert [t.id for t in out] == [1] and len(trk.tracks) == 1


def test_confirm_hits_0_shows_a_track_from_its_first_detection() -> None:
    trk = _tracker(confirm_hits=0)
    box = Box(100, 80, 30, 80)
    assert [t.id for t in trk.step(_frame_with([box]), [Detection(box)])] == [1]
