# SPDX-License-Identifier: Apache-2.0
"""MOT metrics (motmetrics) of the full association on real data: TUD-Campus with its public detections."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import mot_eval

from swir_tracker_ros.acquisition.detectors import MotDetFile
from swir_tracker_ros.acquisition.mot import MotParams, MultiTargetTracker


@pytest.fixture(scope="module")
def tud(shared_dir: Path) -> Path:
    return shared_dir / "data" / "mot" / "tud_campus"


def test_tud_campus_public_detections_full_cost(tud: Path) -> None:
    det = mot_eval.evaluate(mot_eval.tud_frames(tud), MotDetFile(tud / "det.txt"), None)
    trk = MultiTargetTracker(MotParams())
    res = mot_eval.evaluate(mot_eval.tud_frames(tud), MotDetFile(tud / "det.txt"), trk)
    assert res.frames == 71
    # Floors well under the figures the benchmark prints, far above what a broken association gives.
    assert res.mota > 0.25, res
    assert res.idf1 > 0.4, res
    assert res.idsw <= 15, res
    assert res.motp > 0.6, res
    assert res.precision > det.precision  # the life cycle removes isolated false positives
