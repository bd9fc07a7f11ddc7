# SPDX-License-Identifier: Apache-2.0
"""REFERENCE ONLY (tests): the numpy FHOG that swir_tracker_ros/core/fhog.py replaced (issue 17).

Kept verbatim (commit 6db6011) so that test/test_core_fhog.py can pin the compiled-primitive FHOG to the
same numbers on real frames. Not imported by the package.
"""

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


def _orientation_bins(ang: np.ndarray, soft: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orientation bins among the 18 contrast-sensitive ones (centres at multiples of 20 degrees): the
    lower bin ob0, the upper bin ob1 and the weight od of the upper one (1 - od for the lower).

    soft: the two nearest bins share the gradient linearly (Piotr's fhog, softBin = -1); hard: the whole
    gradient goes to the nearest bin (od = 0).
    """
    nb = 2 * N_ORIENT
    o = ang * np.float32(nb / (2.0 * np.pi))
    if soft:
        ob0 = o.astype(np.intp)  # floor, o >= 0
        od = o - ob0.astype(np.float32)
    else:
        ob0 = np.rint(o).astype(np.intp)
        od = np.zeros_like(o)
    ob0[ob0 >= nb] -= nb
    ob1 = ob0 + 1
    ob1[ob1 >= nb] = 0
    return ob0, ob1, od


@lru_cache(maxsize=32)
def _hist_plan(n: int, h: int, w: int, cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-pixel flat indices of its two x cells in a channel-first (18, n*h, wc) accumulator, and the
    two bilinear x weights (the orientation offset bin * n*h*wc is added per frame)."""
    x0, x1, wx0, wx1, _ = _axis_plan(w, cell)
    wc = w // cell
    rows = (np.arange(n * h, dtype=np.intp) * wc).reshape(n, h, 1)
    return rows + x0[None, None, :], rows + x1[None, None, :], wx0, wx1


def orientation_histograms(patches: np.ndarray, cell: int, soft: bool = False) -> np.ndarray:
    """Gradient histograms, channel first (18, N, hc, wc): hard or soft orientation bins
    (`_orientation_bins`), bilinear spatial cells.

    One `np.bincount` (4 entries a pixel: 2 orientation bins x 2 x cells) accumulates straight into the
    channel-first layout the normalisation uses, then `cell` vectorised row passes do the y interpolation.
    (An 18-plane scatter + `cv2.filter2D` variant gave the same numbers but was ~50 % slower here.)
    """
    n, h, w = patches.shape
    mag, ang = gradients(patches)
    nb = 2 * N_ORIENT
    ob0, ob1, od = _orientation_bins(ang, soft)
    m1 = mag * od
    m0 = mag - m1
    hc, wc = h // cell, w // cell
    c0, c1, wx0, wx1 = _hist_plan(n, h, w, cell)
    plane = n * h * wc
    ob0 *= plane
    ob1 *= plane
    npx = n * h * w
    index = np.empty(4 * npx, dtype=np.intp)
    weight = np.empty(4 * npx, dtype=np.float64)
    for q, (cx, ob, wx, m) in enumerate(((c0, ob0, wx0, m0), (c1, ob0, wx1, m0), (c0, ob1, wx0, m1),
                                         (c1, ob1, wx1, m1))):  # 4 vectorised passes
        np.add(cx, ob, out=index[q * npx : (q + 1) * npx].reshape(n, h, w))
        np.multiply(m, wx, out=weight[q * npx : (q + 1) * npx].reshape(n, h, w))
    hx = np.bincount(index, weights=weight, minlength=nb * plane).astype(np.float32)
    return _pool_rows(hx.reshape(nb * n, h, wc), cell).reshape(nb, n, hc, wc)


def cell_histograms(patches: np.ndarray, cell: int, soft: bool = False) -> np.ndarray:
    """`orientation_histograms` as (N, hc, wc, 18) (a view)."""
    return np.moveaxis(orientation_histograms(patches, cell, soft), 0, -1)


def _pool_rows(hx: np.ndarray, cell: int) -> np.ndarray:
    """Bilinear pooling of pixel rows (n, h, k) into cell rows (n, h // cell, k).

    Row r + cell * i sits at cell coordinate i + (r + 0.5) / cell - 0.5: it gives weight 1 - |d| to cell i
    and |d| to the neighbour on the side of d (dropped at the grid border). One pass per row offset r.
    """
    n, h, k = hx.shape
    hc = h // cell
    out = np.zeros((n, hc, k), dtype=np.float32)
    for r in range(cell):  # `cell` (4) vectorised passes, not a loop over pixels
        rows = hx[:, r : r + cell * hc : cell]
        d = (r + 0.5) / cell - 0.5
        out += np.float32(1.0 - abs(d)) * rows
        if d < 0:  # also feeds the cell above
            out[:, :-1] += np.float32(-d) * rows[:, 1:]
        elif d > 0:  # also feeds the cell below
            out[:, 1:] += np.float32(d) * rows[:, :-1]
    return out


def fhog(patches: np.ndarray, cell: int = 4, soft: bool = False) -> np.ndarray:
    """FHOG features of N patches (N, H, W) float32 -> (N, 31, H//cell, W//cell) float32.

    Channels: 18 contrast-sensitive, 9 contrast-insensitive orientation channels, each the average of
    its 4 block-normalised and 0.2-truncated values, then 4 texture (gradient energy) channels, one per
    normalisation block (Felzenszwalb et al., TPAMI 2010, Sec. 6; the variant used by KCF).
    """
    if patches.ndim == 2:
        patches = patches[None]
    patches = np.ascontiguousarray(patches, dtype=np.float32)
    hist = orientation_histograms(patches, cell, soft)  # (18, n, hc, wc)
    _, n, hc, wc = hist.shape
    both = np.empty((3 * N_ORIENT, n, hc, wc), dtype=np.float32)  # 18 sensitive + 9 insensitive
    both[: 2 * N_ORIENT] = hist
    insens = np.add(hist[:N_ORIENT], hist[N_ORIENT:], out=both[2 * N_ORIENT :])
    energy = np.einsum("knij,knij->nij", insens, insens)
    e = np.empty((n, hc + 2, wc + 2), dtype=np.float32)  # edge-replicated border of one cell
    e[:, 1:-1, 1:-1] = energy
    e[:, 0, 1:-1], e[:, -1, 1:-1] = energy[:, 0], energy[:, -1]
    e[:, :, 0], e[:, :, -1] = e[:, :, 1], e[:, :, -2]
    # sum of each 2x2 block of (padded) cells; block (i, j) covers padded cells i..i+1, j..j+1
    blocks = e[:, :-1, :-1] + e[:, 1:, :-1] + e[:, :-1, 1:] + e[:, 1:, 1:]  # (n, hc+1, wc+1)
    inv = 1.0 / np.sqrt(blocks + np.float32(1e-4 / (4.0 * cell**4 * 2.0)))
    out = np.zeros((n, N_CHANNELS, hc, wc), dtype=np.float32)
    orient = np.moveaxis(out[:, : 3 * N_ORIENT], 1, 0)  # (27, n, hc, wc) view
    clip = np.float32(CLIP)
    t = np.empty_like(both)
    for q, norm in enumerate((inv[:, :-1, :-1], inv[:, :-1, 1:], inv[:, 1:, :-1], inv[:, 1:, 1:])):
        np.multiply(both, norm, out=t)  # the 4 normalisation blocks around each cell
        np.minimum(t, clip, out=t)
        orient += t
        out[:, 3 * N_ORIENT + q] = t[: 2 * N_ORIENT].sum(axis=0) * np.float32(TEXTURE_WEIGHT)
    orient *= np.float32(0.5)
    return out
