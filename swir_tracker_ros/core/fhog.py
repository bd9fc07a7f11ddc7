# SPDX-License-Identifier: Apache-2.0
"""Felzenszwalb HOG (FHOG, 31 channels) for a batch of equally sized patches, fully vectorised."""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

N_ORIENT = 9  # contrast-insensitive orientations; 2 * N_ORIENT contrast-sensitive bins
N_CHANNELS = 3 * N_ORIENT + 4  # 18 sensitive + 9 insensitive + 4 texture = 31
CLIP = 0.2
TEXTURE_WEIGHT = 0.2357  # 1 / sqrt(18), as in Felzenszwalb et al. and Dollar's fhog


@lru_cache(maxsize=32)
def _axis_plan(n: int, cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Bilinear pixel -> cell weights along one axis.

    A pixel at coordinate x sits at cell coordinate c = (x + 0.5) / cell - 0.5 and contributes to cells
    floor(c) and floor(c) + 1 with weights 1 - d and d (d = c - floor(c)); contributions outside the
    grid are dropped. Returns (i0, i1, w0, w1, A) with A the dense (n_cells, n) interpolation matrix.
    """
    nc = n // cell
    c = (np.arange(n, dtype=np.float64) + 0.5) / cell - 0.5
    c0 = np.floor(c).astype(np.int64)
    d = c - c0
    i0, i1 = c0, c0 + 1
    w0 = np.where((i0 >= 0) & (i0 < nc), 1.0 - d, 0.0)
    w1 = np.where((i1 >= 0) & (i1 < nc), d, 0.0)
    i0, i1 = np.clip(i0, 0, nc - 1), np.clip(i1, 0, nc - 1)
    A = np.zeros((nc, n), dtype=np.float32)
    np.add.at(A, (i0, np.arange(n)), w0)
    np.add.at(A, (i1, np.arange(n)), w1)
    return i0, i1, w0.astype(np.float32), w1.astype(np.float32), A


def gradients(patches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Magnitude and orientation in [0, 2 pi) of [-1, 0, 1] gradients; one-sided differences at the border."""
    p = patches
    gx = np.empty_like(p)
    gy = np.empty_like(p)
    gx[:, :, 1:-1] = (p[:, :, 2:] - p[:, :, :-2]) * 0.5
    gx[:, :, 0] = p[:, :, 1] - p[:, :, 0]
    gx[:, :, -1] = p[:, :, -1] - p[:, :, -2]
    gy[:, 1:-1, :] = (p[:, 2:, :] - p[:, :-2, :]) * 0.5
    gy[:, 0, :] = p[:, 1, :] - p[:, 0, :]
    gy[:, -1, :] = p[:, -1, :] - p[:, -2, :]
    n, h, w = p.shape
    mag, ang = cv2.cartToPolar(gx.reshape(n * h, w), gy.reshape(n * h, w))
    return mag.reshape(n, h, w), ang.reshape(n, h, w)


def cell_histograms(patches: np.ndarray, cell: int) -> np.ndarray:
    """Gradient histograms, shape (N, hc, wc, 18): hard orientation bins, bilinear spatial interpolation.

    The separable interpolation runs as one bincount along x (two entries per pixel) followed by a
    small matrix product along y.
    """
    n, h, w = patches.shape
    mag, ang = gradients(patches)
    nb = 2 * N_ORIENT
    obin = np.rint(ang * (nb / (2.0 * np.pi))).astype(np.intp)
    obin[obin >= nb] -= nb
    x0, x1, wx0, wx1, _ = _axis_plan(w, cell)
    _, _, _, _, Ay = _axis_plan(h, cell)
    hc, wc = h // cell, w // cell
    rows = (np.arange(n * h, dtype=np.intp) * (wc * nb)).reshape(n, h, 1)
    i0 = rows + x0[None, None, :] * nb + obin
    i1 = rows + x1[None, None, :] * nb + obin
    index = np.concatenate([i0.ravel(), i1.ravel()])
    weight = np.concatenate([(mag * wx0).ravel(), (mag * wx1).ravel()])
    hx = np.bincount(index, weights=weight, minlength=n * h * wc * nb).astype(np.float32)
    hist = np.matmul(Ay, hx.reshape(n, h, wc * nb))  # (n, hc, wc*nb)
    return hist.reshape(n, hc, wc, nb)


def fhog(patches: np.ndarray, cell: int = 4) -> np.ndarray:
    """FHOG features of N patches (N, H, W) float32 -> (N, 31, H//cell, W//cell) float32.

    Channels: 18 contrast-sensitive, 9 contrast-insensitive orientation channels, each the average of
    its 4 block-normalised and 0.2-truncated values, then 4 texture (gradient energy) channels, one per
    normalisation block (Felzenszwalb et al., TPAMI 2010, Sec. 6; the variant used by KCF).
    """
    if patches.ndim == 2:
        patches = patches[None]
    patches = np.ascontiguousarray(patches, dtype=np.float32)
    hist = cell_histograms(patches, cell)  # (n, hc, wc, 18)
    n, hc, wc, _ = hist.shape
    insens = hist[..., :N_ORIENT] + hist[..., N_ORIENT:]
    energy = np.einsum("nijk,nijk->nij", insens, insens)
    e = np.pad(energy, ((0, 0), (1, 1), (1, 1)), mode="edge")
    # sum of each 2x2 block of (padded) cells; block (i, j) covers padded cells i..i+1, j..j+1
    blocks = e[:, :-1, :-1] + e[:, 1:, :-1] + e[:, :-1, 1:] + e[:, 1:, 1:]  # (n, hc+1, wc+1)
    eps = 1e-4 / (4.0 * cell**4 * 2.0)
    inv = 1.0 / np.sqrt(blocks + eps)
    norms = np.stack([inv[:, :-1, :-1], inv[:, :-1, 1:], inv[:, 1:, :-1], inv[:, 1:, 1:]], axis=-1)  # (n,hc,wc,4)
    sens = np.minimum(hist[..., None, :] * norms[..., :, None], CLIP)  # (n, hc, wc, 4, 18)
    ins = np.minimum(insens[..., None, :] * norms[..., :, None], CLIP)  # (n, hc, wc, 4, 9)
    out = np.empty((n, hc, wc, N_CHANNELS), dtype=np.float32)
    out[..., : 2 * N_ORIENT] = 0.5 * sens.sum(axis=3)
    out[..., 2 * N_ORIENT : 3 * N_ORIENT] = 0.5 * ins.sum(axis=3)
    out[..., 3 * N_ORIENT :] = TEXTURE_WEIGHT * sens.sum(axis=4)
    return np.ascontiguousarray(out.transpose(0, 3, 1, 2))
