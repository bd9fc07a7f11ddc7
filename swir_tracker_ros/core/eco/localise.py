# SPDX-License-Identifier: Apache-2.0
"""Sub-grid localisation of the continuous detection score (C-COT Sec. 3.3; ECO reference `optimize_scores`).

The score of a sample is the trigonometric polynomial s(u, v) = sum_k s^[k] exp(i (ky u + kx v)) with u, v in
radians of the period (u = 2 pi t / T, t relative to the sample centre). It is first sampled on the output
grid (one inverse FFT) and maximised there; the maximum is then refined by Newton's method on s itself, with
its analytic gradient and Hessian (on the half spectrum: s = Re sum_{kx >= 0} alpha_kx s^ e^{...}, alpha 1 for
kx = 0 and 2 otherwise). A refinement that ends below the grid maximum is discarded (reference code).
Confidence of the sampled response: PSR (paper 000 eq. 10) and APCE (dissertation eq. 4.94), the measures the
long-term layers use for occlusion detection (core/confidence.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from swir_tracker_ros.core.confidence import apce, psr
from swir_tracker_ros.core.eco.fourier import half_size, sample_grid


@dataclass(frozen=True)
class Peak:
    """Location (ty, tx) of the maximum as a fraction of the period in [-0.5, 0.5), its score, PSR, APCE."""

    ty: float
    tx: float
    value: float
    psr: float
    apce: float


def _terms(sf: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """alpha * s^ (half spectrum weighted for the full-spectrum sum) and the frequency vectors ky, kx."""
    K = half_size(sf.shape[-2])
    a = sf.astype(np.complex128)
    a[..., 1:] *= 2.0
    return a, np.arange(-K, K + 1, dtype=np.float64), np.arange(sf.shape[-1], dtype=np.float64)


def evaluate(sf: np.ndarray, u: float, v: float) -> float:
    """s(u, v) of one half spectrum (2K + 1, Kx + 1)."""
    a, ky, kx = _terms(sf)
    return float((np.exp(1j * ky * u) @ a @ np.exp(1j * kx * v)).real)


def newton(sf: np.ndarray, u: float, v: float, iterations: int) -> tuple[float, float, float]:
    """Newton's method for a maximum of s from (u, v); returns (u, v, s(u, v)) (C-COT Sec. 3.3)."""
    a, ky, kx = _terms(sf)
    for _ in range(iterations):
        ey, ex = np.exp(1j * ky * u), np.exp(1j * kx * v)
        ay, ax = a @ ex, ey @ a  # (rows,), (cols,)
        gu = (1j * ky * ey) @ ay
        gv = ax @ (1j * kx * ex)
        huu = (-(ky**2) * ey) @ ay
        hvv = ax @ (-(kx**2) * ex)
        huv = (1j * ky * ey) @ a @ (1j * kx * ex)
        g = np.array([gu.real, gv.real])
        h = np.array([[huu.real, huv.real], [huv.real, hvv.real]])
        det = h[0, 0] * h[1, 1] - h[0, 1] ** 2
        if not np.isfinite(det) or abs(det) < 1e-20:
            break
        step = np.linalg.solve(h, g)
        u, v = u - float(step[0]), v - float(step[1])
    return u, v, evaluate(sf, u, v)


def _wrap(u: float) -> float:
    """Angle in [-pi, pi)."""
    return (u + math.pi) % (2.0 * math.pi) - math.pi


def localise(sf: np.ndarray, iterations: int, exclusion: int) -> tuple[int, Peak, np.ndarray]:
    """Best of a batch of score spectra (S, 2K + 1, Kx + 1): (index, its peak, its sampled response).

    Each is sampled on the (2K + 1) x (2Kx + 1) grid, its grid maximum refined by `iterations` Newton steps; the
    batch member with the highest refined score wins (reference: the scale of the translation search)."""
    ny, nx = sf.shape[-2], 2 * (sf.shape[-1] - 1) + 1
    grids = sample_grid(sf, ny, nx)
    best: tuple[float, int, float, float] | None = None
    for i in range(sf.shape[0]):
        r, c = divmod(int(np.argmax(grids[i])), nx)
        g = float(grids[i, r, c])
        u0 = 2.0 * math.pi * (r if r <= ny // 2 else r - ny) / ny
        v0 = 2.0 * math.pi * (c if c <= nx // 2 else c - nx) / nx
        u, v, val = newton(sf[i], u0, v0, iterations) if iterations > 0 else (u0, v0, g)
        if not np.isfinite(val) or val < g:
            u, v, val = u0, v0, g
        if best is None or val > best[0]:
            best = (val, i, _wrap(u), _wrap(v))
    assert best is not None
    val, i, u, v = best
    resp = grids[i]
    r, c = divmod(int(np.argmax(resp)), nx)
    peak = Peak(u / (2 * math.pi), v / (2 * math.pi), val, psr(resp, r, c, exclusion), apce(resp))
    return i, peak, resp
