# SPDX-License-Identifier: Apache-2.0
"""ECO maths (core/eco/fourier.py, regularisation.py, localise.py, sample_space.py): pure functions pinned
against direct computations."""

from __future__ import annotations

import math

import numpy as np
import pytest

import swir_tracker_ros.core.eco.fourier as fo
from swir_tracker_ros.core.eco.localise import localise
from swir_tracker_ros.core.eco.regularisation import RegOperator, reg_window_spectrum, squared_kernel
from swir_tracker_ros.core.eco.sample_space import SampleSpace


def keys(x: np.ndarray, a: float = -0.75) -> np.ndarray:
    x = np.abs(x)
    inner = (a + 2) * x**3 - (a + 3) * x**2 + 1
    outer = a * x**3 - 5 * a * x**2 + 8 * a * x - 4 * a
    return np.where(x <= 1, inner, np.where(x < 2, outer, 0.0))


def test_cubic_kernel_ft_matches_quadrature() -> None:
    x = np.linspace(-2, 2, 40001)
    for f in (0.0, 0.1, 0.37, 0.5, 1.3):
        direct = np.trapezoid(keys(x) * np.cos(2 * math.pi * f * x), x)
        assert fo.cubic_kernel_ft(np.array([f]))[0] == pytest.approx(direct, abs=1e-7)
    assert fo.cubic_kernel_ft(np.array([0.0]))[0] == pytest.approx(1.0)


@pytest.mark.parametrize("shape", [(9, 9), (8, 11), (10, 6)])
def test_centred_spectrum_is_the_interpolated_signal(shape: tuple[int, int]) -> None:
    """The half spectrum holds the Fourier coefficients |k| <= K of the periodic kernel-interpolated signal
    J{x}(t) = sum_n x[n] b(t - t_n) (C-COT eq. 1, 4), t_n relative to the sample centre: computed here by
    sampling J on a fine grid and transforming it."""
    rng = np.random.default_rng(0)
    x = rng.standard_normal(shape)
    n, m = shape
    up = 16
    ty = (np.arange(n * up) + 0.5) / up - 0.5 - (n - 1) / 2  # fine grid over one period, cell units
    tx = (np.arange(m * up) + 0.5) / up - 0.5 - (m - 1) / 2

    def kernel_rows(t: np.ndarray, size: int) -> np.ndarray:  # b(t - t_n) periodised, (len(t), size)
        tn = np.arange(size) - (size - 1) / 2
        d = (t[:, None] - tn[None, :] + size / 2) % size - size / 2
        return keys(d)

    J = kernel_rows(ty, n) @ x @ kernel_rows(tx, m).T
    K, Kx = n // 2, m // 2
    ky, kx = np.arange(-K, K + 1), np.arange(Kx + 1)
    ey = np.exp(-2j * math.pi * ky[:, None] * ty[None, :] / n)
    ex = np.exp(-2j * math.pi * tx[:, None] * kx[None, :] / m)
    coeffs = ey @ J @ ex / (n * up * m * up)
    xf = fo.centred_spectrum(x.astype(np.float32))
    assert xf.shape == coeffs.shape
    assert np.allclose(xf, coeffs, atol=2e-3 * np.abs(coeffs).max())


def test_shift_phase_moves_content_to_the_centre() -> None:
    """Multiplying by shift_phase(2 pi d / T) is the circular move of the content at d to the centre."""
    rng = np.random.default_rng(3)
    x = rng.standard_normal((15, 15)).astype(np.float32)
    xf = fo.centred_spectrum(x)
    moved = xf * fo.shift_phase(7, 7, 2 * math.pi * 2 / 15, 2 * math.pi * -2 / 15)
    rolled = fo.centred_spectrum(np.roll(x, (-2, 2), axis=(0, 1)))
    assert np.allclose(moved, rolled, atol=1e-4)


def test_reg_operator_equals_full_spectrum_convolution() -> None:
    wf = reg_window_spectrum((60, 60), (15.0, 10.0), 1e-4, 1e-2, 2.0, 0.05)
    assert np.allclose(wf, wf[::-1, ::-1]) and wf.shape[0] % 2 == 1
    w2 = squared_kernel(wf)
    K = 6
    rng = np.random.default_rng(1)
    full = rng.standard_normal((2 * K + 1, 2 * K + 1)) + 1j * rng.standard_normal((2 * K + 1, 2 * K + 1))
    full = 0.5 * (full + np.conj(full[::-1, ::-1]))  # Hermitian: a real filter
    half = full[:, K:].astype(np.complex64)[None]
    from scipy.signal import convolve2d

    direct = convolve2d(full, w2, mode="same")[:, K:]  # = w2 * f on the filter's own coefficients
    out = RegOperator(w2, K, K).apply(half)[0]
    assert np.allclose(out, direct, atol=1e-5)


def test_localise_finds_a_sub_cell_peak() -> None:
    """A Gaussian bump placed at a non-integer position is found to a small fraction of a cell."""
    n = 25
    ty, tx = 3.3 / n, -5.6 / n  # fractions of the period
    K = n // 2
    sf = fo.gaussian_label(K, K, 2.0, 2.0, (float(n), float(n))) * fo.shift_phase(
        K, K, -2 * math.pi * ty, -2 * math.pi * tx
    )
    i, peak, resp, _ = localise(sf[None], 5, 3)
    assert i == 0 and resp.shape == (n, n)
    assert peak.ty * n == pytest.approx(3.3, abs=0.02) and peak.tx * n == pytest.approx(-5.6, abs=0.02)
    assert peak.value == pytest.approx(1.0, abs=0.01) and peak.psr > 5


def test_sample_space_merges_the_closest_pair_and_keeps_weights_summing_to_one() -> None:
    rng = np.random.default_rng(2)
    space = SampleSpace([(2, 5, 3)], n_components=4, rate=0.1)
    base = [rng.standard_normal((2, 5, 3)).astype(np.complex64) * 10 for _ in range(4)]
    for b in base:
        space.add([b])
        assert space.weights.sum() == pytest.approx(1.0)
    # the 5th sample is nearly a copy of component 2: it merges into it, the count stays 4
    before = space.weights.copy()
    plan = space.add([base[2] + 0.01])
    assert plan.merge_b == -2 and plan.merge_a == 2 and space.count == 4
    assert space.weights.sum() == pytest.approx(1.0)
    assert space.weights[2] == pytest.approx(before[2] * 0.9 + 0.1)
    # a far new sample: the closest EXISTING pair (made close on purpose) is merged, the new one takes a slot
    space2 = SampleSpace([(2, 5, 3)], n_components=3, rate=0.1)
    for b in (base[0], base[0] + 0.05, base[1]):
        space2.add([b])
    plan = space2.add([base[3]])
    assert {plan.merge_a, plan.merge_b} == {0, 1} and plan.new_id == plan.merge_b
    assert np.allclose(space2.samples[0][plan.new_id], base[3])
    assert space2.weights.sum() == pytest.approx(1.0)
    # the Gram matrix stays the inner products of the stored means
    g = np.array([[fo.half_inner(a, b) for b in space2.samples[0]] for a in space2.samples[0]])
    assert np.allclose(space2.gram, g, rtol=1e-4)


def test_compiled_intensity_channels_equal_the_core_ones() -> None:
    from swir_tracker_ros.core.channels import intensity_channels
    from swir_tracker_ros.core.eco.features import BlockSpec, block_features, compiled

    assert compiled() is not None  # numba is a runtime dependency: the compiled path is the one in use
    rng = np.random.default_rng(5)
    patches = rng.random((3, 36, 44)).astype(np.float32)
    for bins in (0, 4):
        out = block_features(patches, BlockSpec("intensity", 4, 3, bins))
        assert np.allclose(out, intensity_channels(patches, 4, bins), atol=1e-6)

