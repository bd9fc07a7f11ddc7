# SPDX-License-Identifier: Apache-2.0
"""Template geometry (core/windows.py `template_size`, the `fft_sizes` option of every filter's Params) and
the one-computation-per-frame training features (core/base.py `training_features`), issue 17.

`fft_sizes` exact (the default, and what the papers describe) keeps the rounded (1 + padding) x target cell
counts; smooth7 / smooth5 move each count to the nearest 7- / 5-smooth number (fast pocketfft sizes) and
every geometry that depends on the template (feature shape, label scale, BACF support) follows it.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.core import kcf, template
from swir_tracker_ros.core.registry import make_filter
from swir_tracker_ros.core.windows import is_smooth, nearest_smooth_count, template_size
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.tracker import Tracker, TrackerParams
from swir_tracker_ros.types import Box


def test_nearest_smooth_count_is_smooth_and_nearest_in_ratio() -> None:
    for prime in (5, 7):
        for n in range(4, 300):
            m = nearest_smooth_count(n, prime)
            assert is_smooth(m, prime)
            if is_smooth(n, prime):
                assert m == n
            # no smooth number is nearer in ratio
            err = max(m / n, n / m)
            better = [k for k in range(4, 2 * n) if is_smooth(k, prime) and max(k / n, n / k) < err]
            assert not better, (n, m, better)
    assert [nearest_smooth_count(n, 7) for n in (62, 31, 59, 41, 13, 14, 21)] == [63, 32, 60, 42, 14, 14, 21]
    assert [nearest_smooth_count(n, 5) for n in (62, 31, 59, 41, 13, 14, 21)] == [64, 32, 60, 40, 12, 15, 20]


def test_template_size_exact_is_the_rounded_window_and_smooth_sizes_are_fft_friendly() -> None:
    # the benchmark's 40x100 target: 25 x 62 cells (62 = 2 x 31, a slow pocketfft size)
    assert template_size(40, 100, 1.5, 4, 1.0) == (100, 248)
    assert template_size(40, 100, 1.5, 4, 1.0, "exact") == (100, 248)
    assert template_size(40, 100, 1.5, 4, 1.0, "smooth7") == (100, 252)
    assert template_size(40, 100, 1.5, 4, 1.0, "smooth5") == (100, 256)
    rng = np.random.default_rng(0)
    for w, h in rng.uniform(8, 200, (200, 2)):
        ew, eh = template_size(w, h, 1.5, 4, 1.0)
        for mode, prime in (("smooth7", 7), ("smooth5", 5)):
            sw, sh = template_size(w, h, 1.5, 4, 1.0, mode)
            assert sw % 4 == sh % 4 == 0 and is_smooth(sw // 4, prime) and is_smooth(sh // 4, prime)
            assert 0.85 < sw / ew < 1.15 and 0.85 < sh / eh < 1.15  # a few per cent finer or coarser


@pytest.mark.parametrize("pipeline", ["kcf", "dcf_ca", "bacf"])
def test_filters_follow_the_smooth_template(pipeline: str) -> None:
    """Feature shape, label scale and (BACF) filter support all follow the smooth template; exact (default)
    keeps the papers' geometry for every base filter."""
    w, h = 34.0, 84.0  # OTB skating1: exact 21 x 52 cells (52 = 4 x 13)
    exact = make_filter(configuration("measured", pipeline).base, w, h)
    assert TrackerParams().base.fft_sizes == "exact"
    p = configuration("measured", pipeline)
    p.base.fft_sizes = "smooth7"
    p.validate()
    smooth = make_filter(p.base, w, h)
    rows, cols = smooth.shape[1:]
    assert is_smooth(rows, 7) and is_smooth(cols, 7)
    assert (smooth.th // smooth.cell, smooth.tw // smooth.cell) == (rows, cols)
    ky, kx = rows / exact.shape[1], cols / exact.shape[2]
    assert smooth.target_cells == pytest.approx(exact.target_cells * math.sqrt(kx * ky))
    if pipeline == "bacf":
        (r0, r1), (c0, c1) = [(s.start, s.stop) for s in (smooth.filter.rows, smooth.filter.cols)]
        assert r1 - r0 == math.floor(h * smooth.model_scale * ky / smooth.cell)
        assert c1 - c0 == math.floor(w * smooth.model_scale * kx / smooth.cell)
    bad = TrackerParams()
    bad.base.fft_sizes = "prime"
    with pytest.raises(ParameterError, match="fft_sizes"):
        bad.validate()


def _sequence(sequences_dir: Path, name: str, n: int) -> tuple[list[np.ndarray], Box, list[Box]]:
    seq = sequences_dir / name
    pngs = sorted(seq.glob("*.png"))[:n]
    gt = [Box(*map(float, line.split(","))) for line in (seq / "gt.txt").read_text().split()[:n]]
    return [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) for f in pngs], gt[0], gt


def _iou(a: Box, b: Box) -> float:
    iw = max(0.0, min(a.x + a.w, b.x + b.w) - max(a.x, b.x))
    ih = max(0.0, min(a.y + a.h, b.y + b.h) - max(a.y, b.y))
    return iw * ih / (a.w * a.h + b.w * b.h - iw * ih)


@pytest.mark.parametrize("mode", ["smooth7", "smooth5"])
def test_a_smooth_template_still_tracks_a_real_sequence(sequences_dir: Path, mode: str) -> None:
    frames, box, gt = _sequence(sequences_dir, "otb_crossing", 60)  # exact 11 x 31 cells -> 12 x 32
    p = TrackerParams()
    p.base.fft_sizes = mode
    assert make_filter(p.base, box.w, box.h).shape[1:] == (32, 12)
    trk = Tracker(p)
    trk.init(frames[0], box)
    ious = [_iou(trk.update(f).box, g) for f, g in zip(frames[1:], gt[1:])]
    assert np.mean(ious) > 0.6 and min(ious) > 0.3


def _track(frames: list[np.ndarray], box: Box, pipeline: str) -> list[tuple]:
    trk = Tracker(configuration("measured", pipeline))
    trk.init(frames[0], box)
    out = []
    for f in frames[1:]:
        r = trk.update(f)
        out.append((r.box, r.state, r.peak, r.psr, r.apce, r.huber_threshold, r.search_mode))
    return out


@pytest.mark.parametrize("pipeline", ["kcf", "dcf_ca"])
def test_training_features_are_computed_once_a_frame_with_the_same_results(
    sequences_dir: Path, pipeline: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The memory (LCT) and the filter train on the same box of a frame: one feature computation, and the
    tracker's results are those of computing the maps for each (bit for bit)."""
    frames, box, _ = _sequence(sequences_dir, "otb_jogging-1", 60)
    calls = {"computed": 0, "training": 0}
    features, training = template.TemplateFilter.features, template.TemplateFilter.training_features
    inside = [False]

    def count_features(self, img, windows):
        calls["computed"] += inside[0]  # feature maps computed for training
        return features(self, img, windows)

    def count_training(self, img, windows):
        calls["training"] += 1
        inside[0] = True
        try:
            return training(self, img, windows)
        finally:
            inside[0] = False

    monkeypatch.setattr(template.TemplateFilter, "features", count_features)
    monkeypatch.setattr(template.TemplateFilter, "training_features", count_training)
    cached = _track(frames, box, pipeline)
    saved = calls["training"] - calls["computed"]
    assert saved > 10  # the memory trained on many frames without a second feature computation

    def uncached(self, img, windows):
        return features(self, img, windows)

    monkeypatch.setattr(template.TemplateFilter, "training_features", uncached)
    assert _track(frames, box, pipeline) == cached


def test_the_memory_and_the_filter_share_one_kcf_training_sample(
    sequences_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """KCF.sample (spectrum and eq. 6 coefficients of the new sample) runs once for both models on a frame
    where both learn, with the results of computing it for each."""
    frames, box, _ = _sequence(sequences_dir, "otb_jogging-1", 60)
    calls = {"sample": 0, "train": 0}
    sample, train = kcf.KCF.sample, kcf.KCF.train

    def count_sample(self, x):
        calls["sample"] += 1
        return sample(self, x)

    def count_train(self, x, rate, prepared=None):
        calls["train"] += 1
        return train(self, x, rate, prepared)

    monkeypatch.setattr(kcf.KCF, "sample", count_sample)
    monkeypatch.setattr(kcf.KCF, "train", count_train)
    shared = _track(frames, box, "kcf")
    assert calls["train"] - calls["sample"] > 10
    monkeypatch.setattr(kcf.KCF, "train", lambda self, x, rate, prepared=None: train(self, x, rate))
    assert _track(frames, box, "kcf") == shared
