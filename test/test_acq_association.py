# SPDX-License-Identifier: Apache-2.0
"""Gated cost matrix, Hungarian assignment and the track life cycle of paper 004 Section 3.1."""

from __future__ import annotations

import numpy as np
import pytest

from swir_tracker_ros.acquisition.association import FORBIDDEN, CostWeights, Detection, assign, cost_matrix
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker, TrackStatus
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
