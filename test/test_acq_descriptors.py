# SPDX-License-Identifier: Apache-2.0
"""Uniform LBP, the edge-orientation LBP descriptor (paper 004 eq. 8-10) and the base cost (eq. 1)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from swir_tracker_ros.acquisition.descriptors import (
    Appearance,
    BaseWeights,
    base_appearance_cost,
    describe,
    dominant_orientation_cells,
    edge_bound,
    edge_lbp_histogram,
    rms_distance,
    siamese_distance,
)
from swir_tracker_ros.acquisition.lbp import N_BINS, lbp_codes, uniform_lut
from swir_tracker_ros.errors import AcquisitionError
from swir_tracker_ros.types import Box


def _texture(seed: int, shape=(200, 100)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return cv2.GaussianBlur(rng.uniform(0, 255, shape).astype(np.float32), (0, 0), 3.0)


def test_uniform_lut_has_58_uniform_codes_and_59_bins() -> None:
    lut = uniform_lut()
    assert lut.shape == (256,)
    assert len(set(lut[lut < 58].tolist())) == 58
    assert int((lut == N_BINS - 1).sum()) == 256 - 58
    assert lut[0] != lut[255] and lut[0] < 58 and lut[255] < 58


def test_lbp_code_of_a_known_neighbourhood() -> None:
    # centre 5; neighbours clockwise from top-left: 9, 1, 9, 1, 9, 1, 9, 1 -> bits 0, 2, 4, 6 (s >= 0)
    img = np.array([[9, 1, 9], [1, 5, 1], [9, 1, 9]], np.uint8)
    img[1, 2], img[2, 1] = 9, 9  # right (bit 3) and bottom (bit 5) neighbours too
    code = int(lbp_codes(img)[1, 1])
    assert code == (1 << 0) | (1 << 2) | (1 << 3) | (1 << 4) | (1 << 5) | (1 << 6)
    assert int(lbp_codes(img, paper_sign=True)[1, 1]) == 255 - code  # paper s(x): 1 for x <= 0, no ties here


def test_dominant_orientation_of_vertical_and_horizontal_edges() -> None:
    x = np.tile(np.arange(40, dtype=np.float32) * 5, (40, 1))  # intensity grows along x: I_Y = 0
    y = x.T.copy()  # grows along y: I_X = 0
    cx, cy = dominant_orientation_cells(x, 10), dominant_orientation_cells(y, 10)
    assert cx.shape == (4, 4)
    assert set(np.unique(cx)) == {4}  # theta = arctan(I_X / 0) = 90 deg -> bin 4 of 9 (20 deg bins)
    assert set(np.unique(cy)) == {0}  # theta = 0


def test_edge_descriptor_is_normalised_and_invariant() -> None:
    img = _texture(1)
    h = edge_lbp_histogram(img)
    assert h.shape == (N_BINS,) and h.sum() == pytest.approx(1.0)
    assert rms_distance(h, h) == 0.0
    assert rms_distance(h, edge_lbp_histogram(2.0 * img + 17.0)) == pytest.approx(0.0, abs=1e-12)
    assert rms_distance(h, edge_lbp_histogram(255.0 - img)) == pytest.approx(0.0, abs=1e-12)
    other = edge_lbp_histogram(_texture(2))
    d = rms_distance(h, other)
    assert 0.0 < d <= edge_bound()
    assert d == pytest.approx(rms_distance(other, h))


def test_rms_distance_is_eq_10() -> None:
    a, b = np.zeros(N_BINS), np.zeros(N_BINS)
    a[0], b[1] = 1.0, 1.0
    assert rms_distance(a, b) == pytest.approx(np.sqrt(2.0 / 59.0)) == pytest.approx(edge_bound())


def test_base_cost_zero_for_identical_and_grows_with_differences() -> None:
    gray = _texture(3, (240, 320)).astype(np.uint8)
    box = Box(50, 40, 40, 100)
    a = describe(gray, box)
    w = BaseWeights()
    assert base_appearance_cost(a, box, a, box, 1.0, w) == pytest.approx(0.0)
    shifted = box.shifted(10, 0)
    b = describe(gray, shifted)
    assert base_appearance_cost(a, box, b, shifted, 1.0, w) > base_appearance_cost(a, box, a, box, 1.0, w)
    assert base_appearance_cost(a, box, a, box, 0.2, w) == pytest.approx(0.8 * w.score)
    with pytest.raises(AcquisitionError):
        describe(gray, Box(1000, 1000, 10, 10))


def test_siamese_distance_is_eq_7() -> None:
    z = np.zeros(59)
    a = Appearance(z, 0.0, 0.0, z, np.zeros(50), np.zeros((4, 30)))
    e, p = np.zeros(50), np.zeros((4, 30))
    e[0] = 0.5
    p[:, 1] = 2.0
    b = Appearance(z, 0.0, 0.0, z, e, p)
    assert siamese_distance(a, b) == pytest.approx(100 * 0.5 + 25 * 4 * 2.0)
    assert siamese_distance(a, Appearance(z, 0.0, 0.0, z)) is None
