# SPDX-License-Identifier: Apache-2.0
"""DSST scale filter (core/scale.py) and its `scale_estimator = "dsst"` option in the base filters.

Real frames from ../shared/data/sequences, zoomed about the ground-truth box centre by known factors, so
the true scale change is known exactly.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core.params import TrackerParams
from swir_tracker_ros.core.scale import DSSTParams, ScaleFilter, scale_patches
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, TrackState


def real_frame(sequences_dir: Path, seq: str, k: int) -> tuple[np.ndarray, Box]:
    pngs = sorted((sequences_dir / seq).glob("*.png"))
    gts = (sequences_dir / seq / "gt.txt").read_text().split()
    img = cv2.imread(str(pngs[k]), cv2.IMREAD_GRAYSCALE).astype(np.float32) / np.float32(255.0)
    return img, Box(*map(float, gts[k].split(",")))


def zoom(img: np.ndarray, cx: float, cy: float, z: float) -> np.ndarray:
    """The image magnified z times about (cx, cy) (a target there becomes z times larger)."""
    M = np.array([[z, 0.0, (1.0 - z) * cx], [0.0, z, (1.0 - z) * cy]])
    return cv2.warpAffine(img, M, img.shape[::-1], flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


@pytest.mark.parametrize("seq", ["otb_crossing", "otb_walking2", "vottir2015_horse"])
def test_scale_filter_recovers_a_known_zoom(sequences_dir: Path, seq: str) -> None:
    img, box = real_frame(sequences_dir, seq, 10)
    sf = ScaleFilter(DSSTParams(), box.w, box.h)
    sf.train(img, box.cx, box.cy, box.w, box.h, 1.0)
    step = DSSTParams().scale_step
    for z in (0.90, 0.95, 1.0, 1.04, 1.10):
        got = sf.estimate(zoom(img, box.cx, box.cy, z), box.cx, box.cy, box.w, box.h)
        # one sample, one frame: within two scale steps (~4 %), on the right side of 1
        assert abs(np.log(got / z)) <= 2.01 * np.log(step), (z, got)
        assert (got - 1.0) * (z - 1.0) > 0 or z == got == 1.0, (z, got)


def test_scale_patches_replicate_the_border_and_resample_to_the_model_size() -> None:
    img = np.tile(np.arange(60, dtype=np.float32), (40, 1))  # a horizontal ramp
    factors = np.array([0.5, 1.0, 2.0])
    out = scale_patches(img, 2.0, 20.0, 20.0, 10.0, factors, 8, 4)
    assert out.shape == (3, 4, 8) and out.dtype == np.float32
    assert out[2].min() == 0.0  # the crop reaches past the left edge: replicated column 0
    inside = scale_patches(img, 30.0, 20.0, 16.0, 8.0, np.array([1.0]), 8, 4)[0]
    np.testing.assert_allclose(inside[0], 22.5 + 2.0 * np.arange(8), atol=1e-4)  # ramp kept: centres


def test_even_scale_count_is_refused() -> None:
    p = TrackerParams()
    p.kcf.dsst.n_scales = 32
    with pytest.raises(ParameterError, match=r"dsst\.n_scales"):
        p.validate()


def test_default_is_the_scale_search(sequences_dir: Path) -> None:
    """The option changes nothing unless chosen: one detection per scaled window, no scale filter."""
    p = TrackerParams()
    assert p.kcf.scale_estimator == "search" and p.dcf_ca.scale_estimator == "search"
    img, box = real_frame(sequences_dir, "otb_crossing", 10)
    trk = Tracker(p)
    trk.init(img, box)
    assert trk._bank.scale_filter is None
    wins = [Box.from_center(box.cx, box.cy, box.w * f * 2.5, box.h * f * 2.5) for f in (0.95, 1.0, 1.05)]
    dets = trk._bank.detect(img, wins, [0.95, 1.0, 1.05])
    assert [d.window for d in dets] == wins and [d.scale for d in dets] == [0.95, 1.0, 1.05]


def zoom_sequence(img: np.ndarray, box: Box, n: int, rate: float) -> list[np.ndarray]:
    return [zoom(img, box.cx, box.cy, rate**k) for k in range(n)]


@pytest.mark.parametrize("pipeline", ["kcf", "dcf_ca"])
def test_tracker_with_dsst_follows_a_zoom(sequences_dir: Path, pipeline: str) -> None:
    """Real frame zoomed 1.5 % a frame for 24 frames (1.43x): the DSST option ends within 5 % of the true
    size and reports `tracking`; each detect call returns one detection per window (the same one)."""
    img, box = real_frame(sequences_dir, "otb_crossing", 10)
    frames = zoom_sequence(img, box, 25, 1.015)
    p = TrackerParams(pipeline=pipeline)
    p.filter_params().scale_estimator = "dsst"
    trk = Tracker(p)
    trk.init(frames[0], box)
    for f in frames[1:]:
        r = trk.update(f)
    true = 1.015 ** (len(frames) - 1)
    assert r.state is TrackState.TRACKING
    assert abs(r.box.w / box.w / true - 1.0) < 0.05 and abs(r.box.h / box.h / true - 1.0) < 0.05, r.box
    assert abs(r.box.cx - box.cx) < 3.0 and abs(r.box.cy - box.cy) < 3.0
    bank = trk._bank
    wins = [Box.from_center(box.cx, box.cy, box.w * f * 2.5, box.h * f * 2.5) for f in (0.95, 1.0, 1.05)]
    dets = bank.detect(frames[-1], wins, [0.95, 1.0, 1.05])
    assert len(dets) == 3 and dets[0] is dets[1] is dets[2] and dets[0].window == wins[1]
    assert np.isfinite(bank.memory_score(2))  # any window index reads the middle window's features


def test_interpolated_response_measures_changes_below_one_step(sequences_dir: Path) -> None:
    """A 1.5 % zoom (below the 2 % step): whole steps can only answer 1.0 or 1.02; the interpolated response
    (fDSST) lands between them and nearer the truth."""
    img, box = real_frame(sequences_dir, "otb_walking2", 10)
    coarse = ScaleFilter(DSSTParams(interpolation=1), box.w, box.h)
    fine = ScaleFilter(DSSTParams(), box.w, box.h)
    for sf in (coarse, fine):
        sf.train(img, box.cx, box.cy, box.w, box.h, 1.0)
    for z in (1.0 / 1.015, 1.015):
        zoomed = zoom(img, box.cx, box.cy, z)
        c = coarse.estimate(zoomed, box.cx, box.cy, box.w, box.h)
        f = fine.estimate(zoomed, box.cx, box.cy, box.w, box.h)
        assert min(abs(np.log(c) - k * np.log(1.02)) for k in (-1, 0, 1)) < 1e-9  # a whole step
        assert abs(np.log(f / z)) < 0.5 * np.log(1.02) and abs(np.log(f / z)) < abs(np.log(c / z)), (z, c, f)
