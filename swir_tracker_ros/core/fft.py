# SPDX-License-Identifier: Apache-2.0
"""FFT helpers shared by the correlation filters (KCF, DCF-CA, BACF): real 2-D transforms, the Gaussian
label's spectrum, the linear kernel correlation."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.fft as sfft


@lru_cache(maxsize=16)
def gaussian_label_spectrum(rows: int, cols: int, sigma: float) -> np.ndarray:
    """rfft2 of the Gaussian regression target, peak 1 shifted to (0, 0) (KCF `gaussian_shaped_labels`)."""
    r = np.arange(rows) - rows // 2
    c = np.arange(cols) - cols // 2
    y = np.exp(-0.5 / sigma**2 * (r[:, None] ** 2 + c[None, :] ** 2))
    y = np.roll(y, (-(rows // 2), -(cols // 2)), axis=(0, 1))
    return sfft.rfft2(y).astype(np.complex64)


def rfft2(x: np.ndarray) -> np.ndarray:
    """Real 2-D FFT over the last two axes (unnormalised forward, as MATLAB fft2)."""
    return sfft.rfft2(x, axes=(-2, -1), workers=1)


def irfft2(xf: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Inverse of `rfft2` back to real maps of `shape` (rows, cols)."""
    return sfft.irfft2(xf, s=shape, axes=(-2, -1), workers=1)


def linear_correlation(zf: np.ndarray, xf: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Spectrum of the linear kernel correlation, sum over channels of zf * conj(xf) / numel."""
    numel = zf.shape[-3] * shape[0] * shape[1]
    return np.einsum("...chw,chw->...hw", zf, np.conj(xf)) / numel
