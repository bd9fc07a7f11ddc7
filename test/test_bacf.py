# SPDX-License-Identifier: Apache-2.0
"""BACF (core/bacf.py): ADMM solves eq. 2 with the filter on the target support, real-patch shifts, params."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.sparse.linalg import LinearOperator, cg

from swir_tracker_ros.configs import configuration
from swir_tracker_ros.core.bacf import BACF, BACFParams
from swir_tracker_ros.core.confidence import analyse
from swir_tracker_ros.core.features import extract_features, feature_shape, sample_patch
from swir_tracker_ros.core.fft import irfft2, rfft2
from swir_tracker_ros.core.filters import BACFFilter
from swir_tracker_ros.core.kcf import KCFParams
from swir_tracker_ros.core.registry import BASE_FILTERS, make_filter
from swir_tracker_ros.core.windows import search_window, template_size
from swir_tracker_ros.errors import ParameterError
from swir_tracker_ros.tracker import Tracker
from swir_tracker_ros.types import Box, TrackState

SEQ = Path(__file__).resolve().parents[2] / "shared" / "data" / "sequences" / "otb_crossing"


def first_frame() -> tuple[np.ndarray, Box]:
    if not (SEQ / "000001.png").is_file():
        pytest.skip(f"real sequence missing: {SEQ}")
    img = cv2.imread(str(SEQ / "000001.png"), cv2.IMREAD_GRAYSCALE).astype(np.float32) / 255.0
    x, y, w, h = np.loadtxt(SEQ / "gt.txt", delimiter=",")[0]
    return img, Box(float(x), float(y), float(w), float(h))


def shifted(img: np.ndarray, dx: float, dy: float) -> np.ndarray:
    M = np.float32([[1, 0, dx], [0, 1, dy]])
    return cv2.warpAffine(img, M, img.shape[::-1], flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)


def setup(p: BACFParams, img: np.ndarray, box: Box) -> tuple[BACF, Box, int, int]:
    win = search_window(box.cx, box.cy, box.w, box.h, p.padding)
    tw, th = template_size(box.w, box.h, p.padding, p.cell_size, 1.0)
    shape = feature_shape(p.feature, th, tw, p.cell_size)
    support = (int(box.h // p.cell_size), int(box.w // p.cell_size))
    return BACF(p, shape, np.sqrt(box.w * box.h) / p.cell_size, support), win, tw, th


def features(img: np.ndarray, win: Box, tw: int, th: int, p: BACFParams) -> np.ndarray:
    return extract_features(sample_patch(img, win, tw, th)[None], p.feature, p.cell_size)


def direct_minimum(f: BACF) -> float:
    """min of eq. 2 over filters on the support, by conjugate gradients on its normal equations."""
    xf, (rows, cols), (rs, cs) = f.model_xf, f.shape, (f.rows, f.cols)
    k, sr, sc = xf.shape[0], rs.stop - rs.start, cs.stop - cs.start

    def forward(v: np.ndarray) -> np.ndarray:  # sum_k x_k (*) h_k
        h = np.zeros((k, rows, cols))
        h[:, rs, cs] = v.reshape(k, sr, sc)
        return irfft2(np.einsum("khw,khw->hw", np.conj(rfft2(h)), xf), (rows, cols))

    def adjoint(r: np.ndarray) -> np.ndarray:
        return irfft2(np.conj(rfft2(r))[None] * xf, (rows, cols))[:, rs, cs].ravel()

    n = k * sr * sc
    op = LinearOperator((n, n), matvec=lambda v: adjoint(forward(v)) + f.params.lambda_ * v)
    sol, info = cg(op, adjoint(irfft2(f.yf, (rows, cols))), maxiter=3000, rtol=1e-10)
    assert info == 0
    h = np.zeros((k, rows, cols), np.float32)
    h[:, rs, cs] = sol.reshape(k, sr, sc)
    return f.objective(h)


def test_admm_filter_lives_on_the_support_and_decreases_the_objective() -> None:
    img, box = first_frame()
    p = BACFParams()
    f, win, tw, th = setup(p, img, box)
    x = features(img, win, tw, th, p)[0]
    y = irfft2(f.yf, f.shape)
    trace = f.train(x, 1.0, iterations=p.admm_iterations)  # the reference's 2 iterations
    assert len(trace) == 2 and trace[1] < trace[0] < 0.5 * float(np.sum(y**2))  # below h = 0
    outside = np.ones(f.shape, bool)
    outside[f.rows, f.cols] = False
    assert f.h is not None and np.all(f.h[:, outside] == 0.0) and np.abs(f.h[:, ~outside]).max() > 0.0
    assert f.h.shape[1:] == f.shape and f.rows.stop - f.rows.start == int(box.h // 4)


def test_admm_converges_to_the_constrained_least_squares_minimum() -> None:
    """With a fixed penalty (beta = 1) ADMM reaches the minimum of eq. 2 that conjugate gradients find."""
    img, box = first_frame()
    p = BACFParams(padding=2.0, admm_mu=1e-3, admm_beta=1.0)
    f, win, tw, th = setup(p, img, box)
    trace = f.train(features(img, win, tw, th, p)[0], 1.0, iterations=400)
    best = direct_minimum(f)
    assert trace[-1] < 0.05 * trace[0]
    assert trace[-1] == pytest.approx(best, rel=0.05), (trace[-1], best)
    assert np.all(np.diff(trace[-100:]) <= 1e-7)  # settled


def test_bacf_recovers_shifts_of_a_real_patch_beyond_the_kcf_window() -> None:
    img, box = first_frame()
    p = BACFParams()
    f, win, tw, th = setup(p, img, box)
    f.train(features(img, win, tw, th, p)[0], 1.0)
    for dx, dy in [(3.0, -2.0), (-6.0, 5.0), (1.2 * box.w, 0.4 * box.h)]:  # the last: a KCF window's edge
        pk = analyse(f.respond(features(shifted(img, dx, dy), win, tw, th, p))[0], 3)
        est = (pk.col * p.cell_size * win.w / tw, pk.row * p.cell_size * win.h / th)
        assert abs(est[0] - dx) < 2.5 and abs(est[1] - dy) < 2.5, (dx, dy, est)


def test_params_validate_and_nest_in_tracker_params() -> None:
    assert BASE_FILTERS["bacf"] is BACFFilter and BACFFilter.Params is BACFParams
    configuration("measured", "bacf").validate()
    for name, value in [("padding", 0.1), ("admm_iterations", 0), ("lambda_", float("nan"))]:
        p = configuration("measured", "bacf")
        setattr(p.base, name, value)
        with pytest.raises(ParameterError, match=f"base.{name}"):
            p.validate()
    assert BACFParams().output_sigma_factor == pytest.approx(1 / 16)
    assert BACFParams().psr_threshold == KCFParams().psr_threshold  # inherited, written once


def test_pipeline_bacf_is_selected_calibrated_and_tracks() -> None:
    img, box = first_frame()
    # scale penalty 1, no trail: BACF was measured with the largest-peak scale pick and the Kalman
    # velocity while re-detecting (before those defaults; with them the PSR at frame 30 is 6.7 and
    # 6.1 instead of 7.1, under the failure threshold 7)
    p = configuration("measured", "bacf")
    p.scale.penalty, p.coast.trail_velocity, p.trail_frames = 1.0, False, 0
    base = make_filter(p.base, box.w, box.h)
    assert isinstance(base, BACFFilter)
    cells = (base.tw // base.cell) * (base.th // base.cell)
    assert cells <= p.base.max_window_cells
    big = make_filter(p.base, 4 * box.w, 4 * box.h)  # a large target: the template is capped
    assert (big.tw // big.cell) * (big.th // big.cell) <= p.base.max_window_cells
    base.initialise(img, box)
    win = search_window(box.cx, box.cy, box.w, box.h, base.padding)
    det = base.detect(img, [win])[0]
    assert det.peak == pytest.approx(p.base.reference_peak, rel=1e-3)  # first-frame self response
    frames = [(cv2.imread(str(SEQ / f"{i:06d}.png"), cv2.IMREAD_GRAYSCALE)) for i in range(1, 31)]
    gt = np.loadtxt(SEQ / "gt.txt", delimiter=",")
    trk = Tracker(p)
    trk.init(frames[0], box)
    for frame in frames[1:]:
        res = trk.update(frame)
    gx, gy, gw, gh = gt[len(frames) - 1]
    assert res.state is TrackState.TRACKING
    assert abs(res.box.cx - (gx + gw / 2)) < 0.3 * gw and abs(res.box.cy - (gy + gh / 2)) < 0.3 * gh


@pytest.mark.parametrize("shape", ["square", "proportional"])
def test_filter_maps_peaks_to_image_pixels_for_both_window_shapes(shape: str) -> None:
    """The tracker hands in proportional windows; a square filter window must still map its peak (and
    the re-detection lattice's) back to the right image pixels."""
    img, box = first_frame()
    base = make_filter(BACFParams(window_shape=shape), box.w, box.h)
    assert (base.tw == base.th) == (shape == "square")
    base.initialise(img, box)
    win = search_window(box.cx, box.cy, box.w, box.h, base.padding)
    dx, dy = 7.0, -5.0
    moved = shifted(img, dx, dy)
    det = base.detect(moved, [win])[0]
    assert abs(det.cx - box.cx - dx) < 1.5 and abs(det.cy - box.cy - dy) < 1.5, (det.cx, det.cy)
    side = np.sqrt(win.w * win.h)
    assert det.window.w == pytest.approx(side if shape == "square" else win.w)
    off = win.shifted(-0.6 * win.w, 0.3 * win.h)  # the lattice around a prediction off the target
    dets, _ = base.detect_lattice(moved, off, 0.35, 2, channels=8)
    best = max(dets, key=lambda d: d.peak)
    assert abs(best.cx - box.cx - dx) < 2.0 and abs(best.cy - box.cy - dy) < 2.0


def test_relative_psr_failure_test() -> None:
    """psr_ratio: a PSR above the absolute threshold still fails below ratio x the mean PSR of the frames
    that updated the model (static structure under the sharp BACF response); off at 0."""
    from swir_tracker_ros.core.base import Detection

    win = Box(0.0, 0.0, 50.0, 50.0)
    tracked = Detection(25.0, 25.0, 0.8, 14.0, 60.0, 1.0, win)
    wall = Detection(25.0, 25.0, 0.35, 8.0, 25.0, 1.0, win)
    for ratio, expected in [(0.6, True), (0.0, False)]:
        base = make_filter(BACFParams(psr_ratio=ratio), 10.0, 10.0)
        assert not base.failed(wall)  # no updated frame yet: the absolute threshold (7) alone
        for _ in range(3):
            assert not base.failed(tracked) and base.confident(tracked)
        assert base.failed(wall) is expected


def test_psr_is_taken_around_the_peak_over_psr_window_target_sizes() -> None:
    """A look-alike beyond 2.5 target sizes from the peak (inside the 5x window) leaves the PSR as a
    kcf window would see it; one next to the peak still lowers it."""
    from swir_tracker_ros.core.confidence import psr

    p = BACFParams()
    base = make_filter(p, 40.0, 40.0)
    rows, cols = base.shape[1:]
    rng = np.random.default_rng(3)
    far = rng.normal(0.0, 0.02, (rows, cols)).astype(np.float32)
    far[0, 0] = 1.0
    near = far.copy()
    r, c, e = rows // 2, cols // 2, 2 * base.exclusion
    far[r - 1 : r + 2, c - 1 : c + 2] = 0.9  # a look-alike half a window away: outside 2.5 target sizes
    near[e - 1 : e + 2, 0:2] = 0.9  # one just outside the exclusion zone
    k = p.psr_window / (1.0 + p.padding)
    assert base._local_psr(far, k) > 2.0 * psr(far, 0, 0, base.exclusion)
    assert base._local_psr(near, k) < 0.5 * base._local_psr(far, k)
    det = base._detections(far[None], [Box(0.0, 0.0, 200.0, 200.0)], [1.0])[0]
    assert det.psr == pytest.approx(base._local_psr(far, k))
