# SPDX-License-Identifier: Apache-2.0
"""Intensity channels appended to FHOG (core/channels.py; feature kinds hog_gray and hog_ih)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from swir_tracker_ros.core import kernels
from swir_tracker_ros.core.channels import cell_means, intensity_channels, intensity_histogram
from swir_tracker_ros.core.features import extract_features, feature_shape, unwindowed_features
from swir_tracker_ros.core.fhog import N_CHANNELS, fhog


def test_cell_means_average_whole_cells_and_drop_the_rest() -> None:
    planes = np.arange(2 * 1 * 9 * 10, dtype=np.float32).reshape(2, 1, 9, 10)
    out = cell_means(planes, 4)
    assert out.shape == (2, 1, 2, 2) and out.dtype == np.float32
    assert out[1, 0, 1, 0] == pytest.approx(planes[1, 0, 4:8, 0:4].mean())


@pytest.mark.parametrize("cell", [1, 2, 3, 4, 5, 7, 8])
def test_compiled_cell_means_equal_numpy_mean_bit_for_bit(
    cell: int, sequences_dir: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compiled block means (corr_jit.cell_means_kernel, issue 17) are numpy's `mean` exactly, on real
    patches and on the soft histogram planes (hog_ih)."""
    img = cv2.imread(str(sorted((sequences_dir / "otb_woman").glob("*.png"))[0]), cv2.IMREAD_GRAYSCALE)
    patches = np.stack([img[y : y + 250, 40:141] for y in (0, 17, 33)]).astype(np.float32) / 255.0
    for planes in (patches[:, None], intensity_histogram(patches, 8)):
        fast = cell_means(planes, cell)
        monkeypatch.setattr(kernels, "USE_JIT", False)
        slow = cell_means(planes, cell)
        monkeypatch.setattr(kernels, "USE_JIT", True)
        assert fast.shape == slow.shape == (3, planes.shape[1], 250 // cell, 101 // cell)
        np.testing.assert_array_equal(fast, slow)
        assert fast.tobytes() == slow.tobytes()  # bit for bit (signed zeros too)
    if cell < 8:  # the compiled loop did run (cell 8: numpy's unrolled pairwise sum, numpy path kept)
        assert kernels.corr_jit().cell_means_kernel.signatures


def test_intensity_histogram_is_a_soft_partition_of_unity() -> None:
    x = np.array([[[0.0, 1.0 / 16, 0.25, 0.5, 0.99, 1.0]]], dtype=np.float32)
    h = intensity_histogram(x, 8)
    assert h.shape == (1, 8, 1, 6)
    assert np.allclose(h.sum(axis=1), 1.0)
    assert h[0, 0, 0, 0] == 1.0 and h[0, 0, 0, 1] == 1.0  # at or below the first bin centre
    assert h[0, 1, 0, 2] == pytest.approx(0.5) and h[0, 2, 0, 2] == pytest.approx(0.5)  # between 1 and 2
    assert h[0, 7, 0, 5] == 1.0


def test_intensity_separates_what_fhog_cannot() -> None:
    """A uniform bright and a uniform dark patch have the same (zero) FHOG but different intensity
    channels: the thermal blob case the channels are for."""
    bright = np.full((1, 32, 32), 0.9, np.float32)
    dark = np.full((1, 32, 32), 0.2, np.float32)
    assert np.allclose(fhog(bright, 4), fhog(dark, 4))
    fb = unwindowed_features(bright, "hog_ih", 4)
    fd = unwindowed_features(dark, "hog_ih", 4)
    assert fb.shape == (1, N_CHANNELS + 9, 8, 8) == (1, *feature_shape("hog_ih", 32, 32, 4))
    assert np.allclose(fb[0, N_CHANNELS], 0.4) and np.allclose(fd[0, N_CHANNELS], -0.3)
    hist = N_CHANNELS + 1
    assert int(np.argmax(fb[0, hist:, 0, 0])) == 7 and int(np.argmax(fd[0, hist:, 0, 0])) == 1
    assert intensity_channels(bright, 4, 0).shape == (1, 1, 8, 8)


@pytest.mark.parametrize("kind", ["hog_gray", "hog_ih"])
def test_windowed_features_keep_fhog_and_window_the_extras(kind: str) -> None:
    rng = np.random.default_rng(3)
    p = rng.random((2, 40, 60), dtype=np.float32)
    f = extract_features(p, kind, 4)
    assert f.shape == (2, *feature_shape(kind, 40, 60, 4))
    assert np.allclose(f[:, :N_CHANNELS], extract_features(p, "hog_soft", 4), atol=1e-6)
    assert np.allclose(f[:, :, 0, :], 0.0) and np.allclose(f[:, :, :, 0], 0.0)  # Hann window edges
