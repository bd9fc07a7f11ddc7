# SPDX-License-Identifier: Apache-2.0
"""Compiled (numba) loops of the ECO filter's hot path: the adjoint of the data operator in conjugate
gradient, and the intensity channels of a batch of samples in one pass.

Imported through `core/eco/__init__` users only via `compiled()` below (None without numba: the numpy
code runs instead, with the same numbers up to float32 rounding). Compiled on first use, cached on disk.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def adjoint_kernel(x: np.ndarray, t: np.ndarray, out: np.ndarray) -> None:
    """out[d, m] = sum_l conj(x[l, d, m]) t[l, m] (complex64); x (L, D, M), t (L, M), out (D, M)."""
    n_l, n_d, n_m = x.shape
    for d in range(n_d):
        for m in range(n_m):
            out[d, m] = 0
        for l in range(n_l):
            for m in range(n_m):
                a = x[l, d, m]
                b = t[l, m]
                out[d, m] += complex(a.real * b.real + a.imag * b.imag, a.real * b.imag - a.imag * b.real)


@njit(cache=True, nogil=True)
def intensity_cells_kernel(patches: np.ndarray, cell: int, bins: int, out: np.ndarray) -> None:
    """Cell means of the intensity minus 0.5 (channel 0) and of the soft `bins`-bin histogram memberships
    (channels 1..bins) of (N, H, W) patches in [0, 1]: the channels of `core.channels.intensity_channels`.

    A pixel at t = clip(v bins - 0.5, 0, bins - 1) belongs to bin b with weight max(0, 1 - |t - b|) (the two
    nearest bins share it linearly); out (N, 1 + bins, H // cell, W // cell) float32. Row by row into a
    per-cell-row accumulator (contiguous reads, branch-free weights)."""
    n, h, w = patches.shape
    hc, wc = h // cell, w // cell
    inv = np.float32(1.0) / np.float32(cell * cell)
    acc = np.zeros((1 + bins, wc), dtype=np.float32)
    top = np.float32(bins - 1)
    for k in range(n):
        for i in range(hc):
            acc[:, :] = 0.0
            for y in range(i * cell, (i + 1) * cell):
                for x in range(wc * cell):
                    j = x // cell
                    v = patches[k, y, x]
                    acc[0, j] += v
                    t = min(max(v * bins - np.float32(0.5), np.float32(0.0)), top)
                    for b in range(bins):
                        acc[1 + b, j] += max(np.float32(0.0), np.float32(1.0) - abs(t - np.float32(b)))
            for j in range(wc):
                out[k, 0, i, j] = acc[0, j] * inv - np.float32(0.5)
            for b in range(bins):
                for j in range(wc):
                    out[k, 1 + b, i, j] = acc[1 + b, j] * inv
