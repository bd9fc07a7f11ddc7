# SPDX-License-Identifier: Apache-2.0
"""OTB metrics: precision/success curves, AUC, centre error, lost frames, per-sequence means."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swir_tracker_ros.errors import HarnessError
from swir_tracker_ros.harness.evaluate import Run
from swir_tracker_ros.harness.metrics import (
    PRECISION_THRESHOLDS,
    SUCCESS_THRESHOLDS,
    auc,
    center_errors,
    overlaps,
    precision_curve,
    score,
    success_curve,
)
from swir_tracker_ros.harness.plots import mean_curves
from swir_tracker_ros.harness.protocol import RunStats
from swir_tracker_ros.types import Box

GT = Box(100, 100, 20, 40)


def test_threshold_grids():
    assert PRECISION_THRESHOLDS[0] == 0 and PRECISION_THRESHOLDS[-1] == 50 and len(PRECISION_THRESHOLDS) == 51
    assert len(SUCCESS_THRESHOLDS) == 21 and SUCCESS_THRESHOLDS[1] == 0.05 and SUCCESS_THRESHOLDS[-1] == 1.0


def test_center_errors_skip_absent_gt_and_penalise_missing_boxes():
    pred = [GT.shifted(3, 4), None, GT, GT.shifted(30, 0)]
    gt = [GT, GT, None, GT]
    err = center_errors(pred, gt)
    np.testing.assert_allclose(err, [5.0, math.inf, 30.0])
    with pytest.raises(HarnessError):
        center_errors(pred[:2], gt)


def test_precision_curve_counts_le_threshold():
    err = np.array([0.0, 5.0, 20.0, 20.5, math.inf])
    pc = precision_curve(err)
    assert pc[0] == pytest.approx(0.2) and pc[20] == pytest.approx(0.6) and pc[50] == pytest.approx(0.8)
    assert np.all(np.diff(pc) >= 0)


def test_success_curve_and_auc():
    ious = overlaps([GT, GT.shifted(10, 0), None], [GT, GT, GT])
    np.testing.assert_allclose(ious, [1.0, 1 / 3, 0.0])
    sc = success_curve(ious)
    assert sc[0] == pytest.approx(2 / 3)  # IoU > 0
    assert sc[-1] == 0.0  # nothing exceeds IoU 1
    assert sc[6] == pytest.approx(2 / 3) and sc[7] == pytest.approx(1 / 3)  # 0.30 < 1/3 < 0.35
    assert auc(sc) == pytest.approx(np.mean(sc))
    # AUC equals the mean IoU up to the grid quantisation (OTB identity)
    perfect = success_curve(np.ones(10))
    assert auc(perfect) == pytest.approx(20 / 21)


def test_score_fields_and_lost_frames():
    pred = [GT, GT.shifted(2, 0), None, GT.shifted(100, 0), GT]
    gt = [GT, GT, GT, GT, None]
    s = score(pred, gt, seconds=0.5, occluded=[False, False, True, True, None])
    assert s.frames == 4 and s.lost_frames == 2  # no box, and a box without overlap
    assert s.precision_20 == pytest.approx(0.5)
    assert s.center_error == pytest.approx((0 + 2 + 100) / 3)
    assert s.fps == pytest.approx(10.0)
    assert s.occluded_precision_20 == 0.0
    assert set(s.summary()) >= {"precision_20", "success_auc", "center_error", "lost_frames", "fps"}


def test_mean_curves_weigh_sequences_equally():
    a = RunStats.of(Run([GT] * 11, [GT] * 11, [None] * 11, 1.0, ["init"] + ["tracking"] * 10, [None] * 11,
                        GT), 25.0)
    b = RunStats.of(Run([GT, None, None], [GT] * 3, [None] * 3, 1.0, ["init", "lost", "lost"], [None] * 3,
                        GT), 25.0)
    assert (a.frames, b.frames) == (10, 2) and b.precision_20 == 1.0  # failure keeps the start box here
    c = RunStats.of(Run([GT, None], [GT] * 2, [None] * 2, 1.0, ["init", "unanswered"], [None] * 2, GT), 25.0)
    m = mean_curves([a, c])
    assert m.precision_20 == pytest.approx(0.5) and m.frames == 11 and len(m.precision_curve) == 51
