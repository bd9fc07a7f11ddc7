# SPDX-License-Identifier: Apache-2.0
"""The network's gone verdict (policies/gone.py): the cues on a hand-made map, the verdict on synthetic
score maps (a sharp single peak is the target, a flat or low map is gone) and its hysteresis. No model, no
corpus."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from swir_tracker_ros.core.siamese.crops import CropWindow
from swir_tracker_ros.core.siamese.maps import Boxes
from swir_tracker_ros.core.siamese.tracker import SiameseDetection
from swir_tracker_ros.paramfield import validate_params
from swir_tracker_ros.policies.gone import GoneCues, GoneParams, GoneVerdict, cues, second_peak
from swir_tracker_ros.types import Box

S = 15  # v3's map side


def detection(score_map: np.ndarray, index: tuple[int, int] | None = None,
              shift: tuple[float, float] = (0, 0), pscore: float | None = None,
              penalty: float = 1.0) -> SiameseDetection:
    """A search with this score map; the chosen point is its argmax unless given; every point's box is 40 x
    30 crop px at the grid point, the chosen one moved by `shift`."""
    m = np.asarray(score_map, dtype=np.float64)
    n = m.shape[0]
    r, c = index if index is not None else np.unravel_index(int(np.argmax(m)), m.shape)
    k = (np.arange(n) - n // 2) * 16.0
    cx, cy = np.tile(k, (n, 1)), np.tile(k[:, None], (1, n))
    cx[r, c], cy[r, c] = shift
    boxes = Boxes(cx, cy, np.full((n, n), 40.0), np.full((n, n), 30.0))
    box = Box.from_center(100.0, 100.0, 20.0, 15.0)
    score = float(m[r, c])
    chosen = score if pscore is None else pscore
    return SiameseDetection(box=box, smoothed=box, score=score, pscore=chosen, penalty=penalty, lr=0.1,
                            index=(int(r), int(c)), score_map=m, penalised_map=m, penalty_map=np.ones_like(m),
                            boxes=boxes, window=CropWindow(0, 0, 255, 255), center=(100.0, 100.0), scale=2.0,
                            seconds=0.0)


def sharp(n: int = S, peak: float = 0.98, floor: float = 0.002, seed: int = 0) -> np.ndarray:
    """A target: one Gaussian peak of 1.5 points at the centre over a near-zero map."""
    y, x = np.mgrid[:n, :n] - n // 2
    m = floor + (peak - floor) * np.exp(-(x * x + y * y) / (2 * 1.5 ** 2))
    return m + np.random.default_rng(seed).uniform(0, floor, (n, n))


def flat(n: int = S, level: float = 0.3, seed: int = 0) -> np.ndarray:
    """Nothing there: a map of similar values everywhere (background, clutter)."""
    return level * (1.0 + np.random.default_rng(seed).uniform(-0.5, 0.5, (n, n)))


def test_cues_of_a_hand_made_map():
    m = np.zeros((9, 9))
    m[4, 4], m[0, 0] = 1.0, 0.5
    c = cues(detection(m, shift=(30.0, 40.0), pscore=0.7, penalty=0.9))
    # sidelobe: the 81 - 25 = 56 points outside the 5 x 5 around (4, 4): one 0.5, 55 zeros
    mean = 0.5 / 56
    std = math.sqrt(0.25 / 56 - mean ** 2)
    assert c.psr == pytest.approx((1.0 - mean) / std)
    assert c.psr == pytest.approx(14.967, abs=1e-3)
    assert c.apce == pytest.approx(1.0 / ((1.0 + 0.25) / 81))  # |1 - 0|^2 / mean(m^2) = 64.8
    assert c.second == pytest.approx(0.5)
    assert c.mass == pytest.approx(1.5 / 81)
    assert c.disp == pytest.approx(50.0 / 255)  # hypot(30, 40) crop px over the 255 px search side
    assert (c.score, c.pscore, c.penalty, c.peak) == (1.0, 0.7, 0.9, 1.0)


def test_second_peak_leaves_out_only_the_5x5_around_the_chosen_point():
    m = np.zeros((9, 9))
    m[4, 4], m[6, 6], m[7, 7] = 0.8, 0.6, 0.2
    assert second_peak(m, 4, 4) == pytest.approx(0.2 / 0.8)  # (6, 6) is inside the 5 x 5
    m[0, 8] = 0.4
    assert second_peak(m, 4, 4) == pytest.approx(0.5)
    assert second_peak(m, 1, 1) == 0.0  # the chosen value is 0
    assert second_peak(np.zeros((9, 9)), 4, 4) == 0.0


def test_shipped_params_are_valid():
    validate_params(GoneParams())


def test_a_sharp_single_peak_is_not_gone():
    v = GoneVerdict()
    assert not any(v.judge(detection(sharp(seed=k))) for k in range(30))


def test_a_flat_or_low_map_is_gone():
    v = GoneVerdict()
    for k in range(10):
        assert not v.judge(detection(sharp(seed=k)))
    assert v.judge(detection(flat(seed=1)))
    assert v.judge(detection(flat(level=0.02, seed=2)))
    v.reset()
    assert v.judge(detection(flat(seed=3)))  # also without a history


def test_hysteresis_needs_a_stricter_bar_to_resume():
    """Between the two bars the verdict keeps what it said last."""
    v = GoneVerdict(replace(GoneParams(), psr_gone=8.0, psr_resume=16.0, score_gone=0.0))

    def at(psr_value: float, score: float = 0.99) -> bool:
        return v.judge_cues(GoneCues(score, 0.8, 1.0, 0.99, psr_value, 30.0, 0.1, 0.05, 0.0))

    assert not at(12.0)
    assert at(6.0)
    assert at(12.0)  # not found again yet
    assert not at(20.0)
    assert not at(12.0)  # tracking again: the lower bar
    assert at(6.0)
    v.reset()
    assert not at(12.0)  # a new target starts tracked
    no_hysteresis = GoneVerdict(replace(v.p, psr_resume=8.0))
    assert [no_hysteresis.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, s, 30.0, 0.1, 0.05, 0.0))
            for s in (6.0, 12.0)] == [True, False]
    below = GoneVerdict(replace(v.p, psr_resume=2.0))  # a resume bar under the gone bar: no hysteresis
    assert [below.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, s, 30.0, 0.1, 0.05, 0.0))
            for s in (6.0, 12.0)] == [True, False]


def test_score_floor():
    v = GoneVerdict(replace(GoneParams(), psr_gone=8.0, psr_resume=16.0, score_gone=0.5))
    sharp_cues = GoneCues(0.99, 0.8, 1.0, 0.99, 500.0, 30.0, 0.1, 0.05, 0.0)
    assert not v.judge_cues(sharp_cues)
    assert v.judge_cues(replace(sharp_cues, score=0.4))  # a peak that stands out but is not the target
    assert not v.judge_cues(sharp_cues)  # found again: PSR 500 >= 16


def test_relative_resume_bar_follows_the_typical_psr_of_the_tracked_frames():
    """With resume_ratio on, a target tracked at PSR ~12 is found again at PSR 12, not at psr_resume."""
    v = GoneVerdict(replace(GoneParams(), psr_gone=3.5, psr_resume=40.0, score_gone=0.0, resume_ratio=1.0,
                            history=5))

    def at(psr_value: float) -> bool:
        return v.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, psr_value, 30.0, 0.1, 0.05, 0.0))

    assert v.resume_bar() == 40.0  # no tracked frame yet
    assert not any(at(12.0) for _ in range(20))
    assert v.resume_bar() == pytest.approx(12.0)
    assert at(3.0)
    assert at(10.0)  # below the typical 12
    assert not at(12.5)
    off = GoneVerdict(replace(v.p, resume_ratio=0.0))
    assert not off.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, 12.0, 30.0, 0.1, 0.05, 0.0))
    assert off.resume_bar() == 40.0


def test_shipped_rule_is_the_calibrated_one():
    p = GoneParams()
    assert (p.psr_gone, p.psr_resume, p.score_gone, p.resume_ratio) == (3.5, 40.0, 0.7, 0.0)


def test_a_sudden_drop_from_the_typical_psr_is_gone():
    """psr_drop: a target tracked at PSR ~10^4 whose map falls to PSR 10 (hidden behind an occluder) is gone,
    although 10 is above psr_gone; a target always tracked at PSR 10 is not."""
    p = replace(GoneParams(), psr_gone=3.5, psr_resume=40.0, score_gone=0.0, psr_drop=0.005, history=5)

    def run(psrs: list[float]) -> list[bool]:
        v = GoneVerdict(p)
        return [v.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, s, 30.0, 0.1, 0.05, 0.0)) for s in psrs]

    assert run([1e4] * 10 + [10.0, 10.0, 1e4]) == [False] * 10 + [True, True, False]
    assert not any(run([10.0] * 13))
    off = GoneVerdict(replace(p, psr_drop=0.0))
    assert not any(off.judge_cues(GoneCues(0.99, 0.8, 1.0, 0.99, s, 30.0, 0.1, 0.05, 0.0))
                   for s in [1e4] * 10 + [10.0])
