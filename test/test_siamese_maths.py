# SPDX-License-Identifier: Apache-2.0
"""The Siamese tracker's maths as pure functions: crop geometry (SiamFC), point grid, softmax, ltrb decoding
(SiamBAN eq. 3), change penalty and cosine window (SiamRPN eq. 13-14), size update, clipping."""

from __future__ import annotations

import math

import numpy as np
import pytest

from swir_tracker_ros.core.siamese.crops import blob, context_side, crop_window, cut, cut_subpixel
from swir_tracker_ros.core.siamese.maps import (
    Boxes,
    change_penalty,
    clip_state,
    cosine_window,
    decode_ltrb,
    point_grid,
    size_update,
    softmax_score,
    window_mix,
)


def test_context_side_is_siamfc_s_z() -> None:
    # w 20, h 10: p = 0.5 * 30 = 15, s_z = sqrt(35 * 25)
    assert context_side(20, 10, 0.5) == pytest.approx(math.sqrt(35 * 25))
    assert context_side(20, 10, 0.0) == pytest.approx(math.sqrt(200))


def test_whole_pixel_window_is_the_authors_placement() -> None:
    # continuous centre 50.5 = pixel index 50; odd side 11 -> floor(50 - 6 + 0.5) = 44: pixels 44..54,
    # centred on pixel 49 (one pixel left of the target, as the authors' floor puts it)
    w = crop_window(50.5, 40.5, 11.2, 127)
    assert (w.x0, w.y0, w.side) == (44, 34, 11) and w.center == (49.5, 39.5)
    # even side 10 -> pixels 45..54 (centre index 49.5, half a pixel left, as the authors' floor puts it)
    w = crop_window(50.5, 40.5, 10.4, 127)
    assert (w.x0, w.side) == (45, 10) and w.scale == pytest.approx(12.7)


def test_whole_pixel_cut_pads_with_the_truncated_mean() -> None:
    img = np.full((20, 30), 100, np.uint8)
    img[0, 0] = 200
    patch = cut(img, crop_window(0.5, 0.5, 5, 5), np.float64(77.9))  # pixels -3..1 around pixel (0, 0)
    assert patch.shape == (5, 5) and patch[3, 3] == 200 and patch[0, 0] == 77 and patch[4, 4] == 100
    assert (patch[:3] == 77).all() and (patch[:, :3] == 77).all()


def test_subpixel_cut_samples_where_the_geometry_says() -> None:
    """On a linear ramp bilinear sampling is exact: output pixel u samples image index
    cx - side/2 + (u + 1/2) side/out - 1/2."""
    ys, xs = np.mgrid[0:200, 0:300].astype(np.float32)
    ramp = 0.5 * xs + 0.25 * ys
    cx, cy, side, out = 140.3, 95.8, 73.7, 31
    patch = cut_subpixel(ramp, cx, cy, side, out, 0.0)
    u = np.arange(out)
    x = cx - side / 2 + (u + 0.5) * side / out - 0.5
    y = cy - side / 2 + (u + 0.5) * side / out - 0.5
    want = 0.5 * x[None, :] + 0.25 * y[:, None]
    # cv2.warpAffine places its samples to 1/32 px (INTER_BITS 5): error <= (0.5 + 0.25) / 64
    assert np.abs(patch - want).max() < 0.75 / 64 + 1e-4
    # outside the frame: the fill colour, per channel
    bgr = np.zeros((10, 10, 3), np.uint8)
    far = cut_subpixel(bgr, -100.0, -100.0, 20.0, 9, np.array([10.0, 20.0, 30.0]))
    assert far.shape == (9, 9, 3) and (far[4, 4] == [10, 20, 30]).all()


def test_blob_replicates_one_channel_to_three() -> None:
    patch = np.arange(12, dtype=np.uint8).reshape(3, 4)
    b = blob(patch)
    assert b.shape == (1, 3, 3, 4) and b.dtype == np.float32
    assert all((b[0, c] == patch).all() for c in range(3))


def test_point_grid_is_the_authors_offsets() -> None:
    px, py = point_grid(16, 16)
    assert px[0, 0] == -128 and px[0, 15] == 112 and py[15, 0] == 112 and (px[:, 3] == px[0, 3]).all()
    px, py = point_grid(15, 16)
    assert px[0, 0] == -112 and px[0, 14] == 112 and px[7, 7] == 0 and py[7, 7] == 0


def test_softmax_score_is_the_foreground_probability() -> None:
    cls = np.zeros((2, 3, 3), np.float32)
    cls[1] = math.log(3.0)
    cls[0, 1, 2] = 1000.0  # no overflow
    s = softmax_score(cls)
    assert s[0, 0] == pytest.approx(0.75) and s[1, 2] == pytest.approx(0.0)


def test_ltrb_decoding_of_a_synthetic_map() -> None:
    px, py = point_grid(15, 16)
    loc = np.zeros((4, 15, 15), np.float32)
    loc[0], loc[1], loc[2], loc[3] = 5.0, 8.0, 15.0, 12.0  # l, t, r, b
    b = decode_ltrb(loc, px, py)
    # x1 = p - 5, x2 = p + 15 -> cx = p + 5, w = 20; y1 = p - 8, y2 = p + 12 -> cy = p + 2, h = 20
    assert np.allclose(b.cx, px + 5) and np.allclose(b.cy, py + 2)
    assert np.allclose(b.w, 20) and np.allclose(b.h, 20)


def test_change_penalty_is_siamrpn_eq_13() -> None:
    w = np.full((1, 2), 20.0)
    h = np.full((1, 2), 10.0)
    w[0, 1], h[0, 1] = 40.0, 20.0  # same ratio, double size: s_c = 2, r_c = 1
    pen = change_penalty(Boxes(w * 0, h * 0, w, h), 20.0, 10.0, 0.15)
    assert pen[0, 0] == pytest.approx(1.0) and pen[0, 1] == pytest.approx(math.exp(-0.15))
    # ratio change only: 20x10 -> 10x20 keeps the size measure, r_c = 4
    flip = Boxes(np.zeros(1), np.zeros(1), np.array([10.0]), np.array([20.0]))
    pen = change_penalty(flip, 20.0, 10.0, 0.15)
    assert pen[0] == pytest.approx(math.exp(-3 * 0.15))


def test_window_size_update_and_clip() -> None:
    win = cosine_window(16)
    assert win.shape == (16, 16) and win.max() < 1.0 and win[0, 0] == 0.0
    mixed = window_mix(np.ones((16, 16)), win, 0.49)
    assert mixed[0, 0] == pytest.approx(0.51) and np.argmax(mixed) == np.argmax(win)
    assert size_update(20.0, 10.0, 40.0, 30.0, 0.25) == (25.0, 15.0)
    assert clip_state(-5.0, 300.0, 4.0, 500.0, 320, 240, 10.0) == (0.0, 240.0, 10.0, 240.0)
