# SPDX-License-Identifier: Apache-2.0
"""Spatial regularisation of the filter in the Fourier domain (SRDCF, Danelljan et al., ICCV 2015; C-COT eq.
10-12).

The filter's energy away from the target is penalised by a window w(t) that is smallest on the target and
grows quadratically outward: w(t) = w_min + (w_edge - w_min) (|ty / sy|^p + |tx / sx|^p), s = half the target
size (the reference code's `get_reg_filter`, p = 2). The term ||w f||^2 of the loss becomes, with the Fourier
coefficients w^ of w, ||w^ * f^||^2 (C-COT eq. 10, `*` a discrete convolution of coefficient sequences), and
the
normal equations need W^H W f^ = w^ * (w^ * f^) (C-COT eq. 12). w^ is made sparse: coefficients below
`sparsity` x the largest are dropped, then the DC is raised so that the sparse window's minimum is w_min again
(reference code). With the origin at the sample centre (core/eco/fourier.py) w^ is real and even.

W^H W is applied as ONE convolution with w2^ = w^ * w^ (associative; the intermediate is never truncated),
restricted to the filter's own coefficients, on the half spectrum (the negative columns it reads come from
Hermitian symmetry).
"""

from __future__ import annotations

import numpy as np
import scipy.fft as sfft
from scipy.signal import convolve2d

from swir_tracker_ros.core.eco.fourier import half_size


def reg_window_spectrum(
    support: tuple[int, int],
    target: tuple[float, float],
    w_min: float,
    w_edge: float,
    power: float,
    sparsity: float,
) -> np.ndarray:
    """The sparse, real, centred coefficients w^ (odd x odd, float64) of the regularisation window.

    support: (rows, cols) of the image sample in sample pixels (the period); target: (h, w) of the target in
    the same pixels. The window is sampled on that pixel grid with the origin at index 0 (FFT order), its DFT
    divided by the pixel count gives the Fourier series coefficients (reference code)."""
    ny, nx = support
    ty = np.fft.fftfreq(ny, 1.0 / ny)  # 0, 1, ..., -1: the position of each row relative to the centre
    tx = np.fft.fftfreq(nx, 1.0 / nx)
    sy, sx = 0.5 * target[0], 0.5 * target[1]
    win = (w_edge - w_min) * (np.abs(ty[:, None] / sy) ** power + np.abs(tx[None, :] / sx) ** power) + w_min
    wf = sfft.fft2(win, workers=1).real / (ny * nx)  # real: the window is even about index 0
    wf[np.abs(wf) < sparsity * np.abs(wf).max()] = 0.0
    sparse = sfft.ifft2(wf, workers=1).real * (ny * nx)
    wf[0, 0] += w_min - sparse.min()
    wf = np.fft.fftshift(wf)
    rows = np.nonzero(np.any(wf != 0.0, axis=1))[0]
    cols = np.nonzero(np.any(wf != 0.0, axis=0))[0]
    cy, cx = ny // 2, nx // 2  # the fftshifted centre
    ry = max(cy - rows[0], rows[-1] - cy)
    rx = max(cx - cols[0], cols[-1] - cx)
    return wf[cy - ry : cy + ry + 1, cx - rx : cx + rx + 1].copy()


def squared_kernel(wf: np.ndarray) -> np.ndarray:
    """w2^ = w^ * w^ (full 2-D convolution of the coefficients): W^H W as one convolution (C-COT eq. 12)."""
    return convolve2d(wf, wf, mode="full")


class RegOperator:
    """W^H W on half spectra (D, 2K + 1, Kx + 1) of one block, for a fixed kernel w2^ (odd x odd, real)."""

    def __init__(self, w2: np.ndarray, k_y: int, k_x: int) -> None:
        self.k_y, self.k_x = k_y, k_x
        self.ry, self.rx = half_size(w2.shape[0]), half_size(w2.shape[1])
        taps = np.argwhere(w2 != 0.0)
        self.taps = [(int(a) - self.ry, int(b) - self.rx, np.float32(w2[a, b])) for a, b in taps]
        self.energy = float(
            np.sum(w2[self.ry, self.rx])
        )  # w2^[0] = sum w^2 = ||w^||^2, for the preconditioner

    def apply(self, f: np.ndarray) -> np.ndarray:
        """out[ky, kx] = sum_{dy, dx} w2^[dy, dx] f^[ky - dy, kx - dx] for the filter's own (ky, kx)."""
        d, ny, nx = f.shape
        ry, rx = self.ry, self.rx
        # extended array: rows -K - ry .. K + ry, columns -rx .. Kx + rx (zeros beyond the filter)
        ext = np.zeros((d, ny + 2 * ry, nx + 2 * rx), dtype=f.dtype)
        ext[:, ry : ry + ny, rx : rx + nx] = f
        m = min(rx, nx - 1)
        if m > 0:  # columns -1..-m from Hermitian symmetry: f^[ky, -j] = conj(f^[-ky, j])
            ext[:, ry : ry + ny, rx - m : rx] = np.conj(f[:, ::-1, m:0:-1])
        out = np.zeros_like(f)
        for dy, dx, w in self.taps:
            out += w * ext[:, ry - dy : ry - dy + ny, rx - dx : rx - dx + nx]
        return out
