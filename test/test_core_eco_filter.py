# SPDX-License-Identifier: Apache-2.0
"""ECO base filter on real frames (core/eco/filter.py): the mechanisms, not a tracking score."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

import swir_tracker_ros.core.eco.optimise as opt
from swir_tracker_ros.core.eco.filter import ECOFilter
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.core.eco.tracker import ECOTracker
from swir_tracker_ros.types import Box


def frames_and_box(sequences_dir: Path, name: str, count: int) -> tuple[list[np.ndarray], Box]:
    d = sequences_dir / name
    files = sorted(f for f in d.iterdir() if f.suffix in (".png", ".jpg"))[:count]
    frames = [cv2.imread(str(f), cv2.IMREAD_GRAYSCALE).astype(np.float32) / 255.0 for f in files]
    x, y, w, h = (float(v) for v in (d / "gt.txt").read_text().splitlines()[0].replace(",", " ").split()[:4])
    return frames, Box(x, y, w, h)


@pytest.fixture(scope="module")
def crossing(sequences_dir: Path) -> tuple[list[np.ndarray], Box]:
    return frames_and_box(sequences_dir, "otb_crossing", 12)


def test_detect_recovers_a_sub_pixel_shift(crossing: tuple[list[np.ndarray], Box]) -> None:
    frames, box = crossing
    filt = ECOFilter(ECOParams(scale_estimator="none"))
    filt.init(frames[0], box)
    for dx, dy in [(2.6, -1.4), (-4.3, 3.2)]:
        det = filt.detect(frames[0], center=(box.cx + dx, box.cy + dy))
        assert det.cx == pytest.approx(box.cx, abs=0.5) and det.cy == pytest.approx(box.cy, abs=0.5)
        assert det.peak > 0.3 and det.psr > 10 and det.apce > 10
    assert filt.center == (box.cx, box.cy)  # detect does not move the state


def test_first_frame_gauss_newton_lowers_the_joint_loss(crossing: tuple[list[np.ndarray], Box]) -> None:
    frames, box = crossing
    filt = ECOFilter(ECOParams())
    filt.init(frames[0], box)
    losses = filt.init_losses
    assert len(losses) == filt.params.init_gn_iter
    assert losses[-1] < 0.8 * losses[0]
    assert all(b <= a * 1.001 for a, b in itertools.pairwise(losses))


def test_projection_reduces_channels_and_stays_near_orthonormal(
    crossing: tuple[list[np.ndarray], Box],
) -> None:
    frames, box = crossing
    filt = ECOFilter(ECOParams())
    filt.init(frames[0], box)
    hog, intensity = filt.proj
    assert hog.shape == (31, 10) and intensity.shape == (5, 3)
    sv = np.linalg.svd(hog, compute_uv=False)
    assert sv.min() > 0.3 and sv.max() / sv.min() < 5.0  # PCA start (orthonormal), then Gauss-Newton steps


def test_conjugate_gradient_lowers_the_loss_and_warm_start_helps(
    crossing: tuple[list[np.ndarray], Box],
) -> None:
    frames, box = crossing
    p = ECOParams(scale_estimator="none", skip_after_frame=1, train_gap=100)  # no optimisation in update
    filt = ECOFilter(p)
    filt.init(frames[0], box)
    for f in frames[1:10]:
        filt.update(f, filt.detect(f))
    n = filt.space.count
    xs, w = [s[:n] for s in filt.space.samples], filt.space.weights[:n]
    m = opt.preconditioner(filt.energy, filt.regs, p.precond_data, p.precond_reg)
    before = opt.filter_loss(filt.hf, xs, w, filt.yf, filt.regs, filt.out)
    warm, _, res_warm = opt.train_filter(filt.hf, xs, w, filt.yf, filt.regs, filt.out, m, 5, None, 0.0)
    zero = [np.zeros_like(h) for h in filt.hf]
    cold, _, _ = opt.train_filter(zero, xs, w, filt.yf, filt.regs, filt.out, m, 5, None, 0.0)
    after_warm = opt.filter_loss(warm, xs, w, filt.yf, filt.regs, filt.out)
    after_cold = opt.filter_loss(cold, xs, w, filt.yf, filt.regs, filt.out)
    assert after_warm < before
    assert after_warm < after_cold
    assert res_warm[-1] < res_warm[0]


def textured_blob(size: int, rng: np.random.Generator) -> np.ndarray:
    blob = 0.5 + 0.4 * rng.random((size, size))
    yy, xx = np.mgrid[:size, :size]
    blob *= np.exp(-(((yy - size / 2 + 0.5) ** 2 + (xx - size / 2 + 0.5) ** 2) / (0.5 * size**2)))
    return blob.astype(np.float32)


def test_an_8x8_target_is_initialised_and_tracked_while_it_translates() -> None:
    """Issue 31 item 4: a small target (a drone of 8x8 px on a thermal frame) is followed."""
    rng = np.random.default_rng(4)
    bg = cv2.GaussianBlur(rng.random((240, 320)).astype(np.float32), (0, 0), 3) * 0.3
    blob = textured_blob(8, rng)
    trk = ECOTracker()
    x, y = 150.0, 100.0
    for k in range(15):
        img = bg.copy()
        img[int(y) : int(y) + 8, int(x) : int(x) + 8] += blob
        frame = np.clip(img * 255, 0, 255).astype(np.uint8)
        if k == 0:
            trk.init(frame, Box(x, y, 8, 8))
        else:
            out = trk.update(frame)
            assert math.hypot(out.cx - (x + 4), out.cy - (y + 4)) < 2.0, k
            assert 5 < out.w < 13
        x, y = x + 2.0, y - 1.0


def test_uint16_frames_are_conditioned(crossing: tuple[list[np.ndarray], Box]) -> None:
    frames, box = crossing
    trk = ECOTracker()
    trk.init((frames[0] * 4000 + 1000).astype(np.uint16), box)
    out = trk.update((frames[1] * 4000 + 1000).astype(np.uint16))
    assert out.iou(box) > 0.6


def test_detect_windows_finds_the_target_from_a_neighbouring_window(
    crossing: tuple[list[np.ndarray], Box],
) -> None:
    frames, box = crossing
    filt = ECOFilter(ECOParams())
    filt.init(frames[0], box)
    dets = filt.detect_windows(frames[1], [(box.cx + 8, box.cy - 6), (box.cx + 150, box.cy)])
    near, far = dets
    assert math.hypot(near.cx - box.cx, near.cy - box.cy) < 5.0
    assert near.peak > far.peak and near.psr > far.psr


def test_a_gated_update_moves_without_learning(crossing: tuple[list[np.ndarray], Box]) -> None:
    frames, box = crossing
    filt = ECOFilter(ECOParams())
    filt.init(frames[0], box)
    before = (filt.space.count, [h.copy() for h in filt.hf])
    det = filt.detect(frames[1])
    filt.update(frames[1], det, learn=False, center=(det.cx + 3.0, det.cy))
    assert filt.center == (det.cx + 3.0, det.cy)
    assert filt.space.count == before[0] and all(np.array_equal(a, b) for a, b in zip(filt.hf, before[1]))
    filt.update(frames[1], det, learn=True)
    assert filt.space.count == before[0] + 1
