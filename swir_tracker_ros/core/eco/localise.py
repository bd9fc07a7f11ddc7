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


def newton(sf: np.ndarray, u: np.ndarray, v: np.ndarray, iterations: int) -> tuple[np.ndarray, ...]:
    """Newton's method for maxima of a batch of scores (S, 2K + 1, Kx + 1) from (u, v) (S,) each (C-COT Sec.
    3.3): returns (u, v, s(u, v)), each (S,). A member whose Hessian is singular keeps its last point."""
    a, ky, kx = _terms(sf)
    u, v = np.array(u, dtype=np.float64), np.array(v, dtype=np.float64)
    iky, ikx = 1j * ky, 1j * kx
    for _ in range(iterations):
        ey, ex = np.exp(np.outer(u, iky)), np.exp(np.outer(v, ikx))  # (S, rows), (S, cols)
        ay = np.matmul(a, ex[:, :, None])[:, :, 0]  # sum over columns: (S, rows)
        ayx = np.matmul(a, (ikx * ex)[:, :, None])[:, :, 0]  # d/dv of it
        ax = np.matmul(ey[:, None, :], a)[:, 0, :]  # sum over rows: (S, cols)
        dey = iky * ey
        gu = np.sum(dey * ay, axis=1).real
        gv = np.sum(ax * ikx * ex, axis=1).real
        huu = np.sum(iky * dey * ay, axis=1).real
        hvv = np.sum(ax * ikx * ikx * ex, axis=1).real
        huv = np.sum(dey * ayx, axis=1).real
        det = huu * hvv - huv**2
        ok = np.isfinite(det) & (np.abs(det) > 1e-20)
        safe = np.where(ok, det, 1.0)
        u = np.where(ok, u - (hvv * gu - huv * gv) / safe, u)
        v = np.where(ok, v - (huu * gv - huv * gu) / safe, v)
    ey, ex = np.exp(np.outer(u, iky)), np.exp(np.outer(v, ikx))
    val = np.sum(ey * np.matmul(a, ex[:, :, None])[:, :, 0], axis=1).real
    return u, v, val


def _wrap(u: float) -> float:
    """Angle in [-pi, pi)."""
    return (u + math.pi) % (2.0 * math.pi) - math.pi


def localise(sf: np.ndarray, iterations: int, exclusion: int) -> tuple[int, Peak, np.ndarray, np.ndarray]:
    """Best of a batch of score spectra (S, 2K + 1, Kx + 1): (index, its peak, its sampled response, the
    refined peak value of every member).

    Each is sampled on the (2K + 1) x (2Kx + 1) grid, its grid maximum refined by `iterations` Newton steps
    (a refinement that ends lower is dropped); the member with the highest score wins (reference: the scale
    of the translation search)."""
    n = sf.shape[0]
    ny, nx = sf.shape[-2], 2 * (sf.shape[-1] - 1) + 1
    grids = sample_grid(sf, ny, nx)
    idx = grids.reshape(n, -1).argmax(axis=1)
    r, c = np.divmod(idx, nx)
    g = grids.reshape(n, -1)[np.arange(n), idx].astype(np.float64)
    u0 = 2.0 * math.pi * np.where(r <= ny // 2, r, r - ny) / ny
    v0 = 2.0 * math.pi * np.where(c <= nx // 2, c, c - nx) / nx
    u, v, val = newton(sf, u0, v0, iterations) if iterations > 0 else (u0, v0, g)
    worse = ~np.isfinite(val) | (val < g)
    u, v, val = np.where(worse, u0, u), np.where(worse, v0, v), np.where(worse, g, val)
    i = int(np.argmax(val))
    resp = grids[i]
    peak = Peak(
        _wrap(float(u[i])) / (2 * math.pi),
        _wrap(float(v[i])) / (2 * math.pi),
        float(val[i]),
        psr(resp, int(r[i]), int(c[i]), exclusion),
        apce(resp),
    )
    return i, peak, resp, val
