# SPDX-License-Identifier: Apache-2.0
"""Compiled (numba) loops of the FHOG cell histograms and block normalisation (issue 17).

Imported by core/fhog.py only when numba is installed (requirements.txt pins it); without it fhog.py keeps
its numpy path. Each loop performs, element by element, the same float32 / float64 operations in the same
order as the numpy code it replaces (test/fhog_reference.py), so the features are bit-identical
(test/test_core_fhog.py). The rules that keep them so:

- no `fastmath` (no re-association, no fused multiply-add: LLVM contracts a * b + c only when allowed);
- every constant is cast to float32 where the numpy code had a float32 scalar (a bare Python float would
  promote the arithmetic to float64 in numba);
- the float64 histogram sums keep the reference's order: per accumulator entry, the 4 passes (lower /
  upper orientation bin x left / right cell) in turn, pixels in row order within each pass;
- the row pooling and the normalisation keep the numpy passes' order per output element.

Compiled on first use and cached on disk (`cache=True`: the package's __pycache__, or numba's user-wide
cache directory when that is read-only).
"""

from __future__ import annotations

import numpy as np
from numba import njit

N_ORIENT = 9
N_BINS = 2 * N_ORIENT


@njit(cache=True, nogil=True)
def cell_histograms_kernel(
    mag: np.ndarray,
    ang: np.ndarray,
    h: int,
    cell: int,
    soft: bool,
    x0: np.ndarray,
    x1: np.ndarray,
    wx0: np.ndarray,
    wx1: np.ndarray,
    pool_w: np.ndarray,
    pool_nb: np.ndarray,
    pool_dir: np.ndarray,
    acc: np.ndarray,
    hx: np.ndarray,
    ob0: np.ndarray,
    ob1: np.ndarray,
    m0: np.ndarray,
    m1: np.ndarray,
    out: np.ndarray,
) -> None:
    """Bilinear-cell orientation histograms of N stacked patches.

    mag, ang: (N*h, W) float32 gradient magnitude and angle in [0, 2 pi]. x0, x1, wx0, wx1: each column's
    two x cells and bilinear weights (fhog._axis_plan). pool_w / pool_nb / pool_dir: per row phase r of a
    cell, the float32 weight of its own cell row, of the neighbouring cell row and that neighbour's
    direction (-1, 0, +1) (fhog._pool_plan). acc: (wc*18,) float64, hx: (N*h, wc*18) float32, ob0 / ob1
    (W,) intp, m0 / m1 (W,) float32: scratch. out: (N, hc, wc*18) float32, bin innermost.
    """
    nh, w = mag.shape
    n = nh // h
    hc = h // cell
    k = out.shape[2]
    scale = np.float32(N_BINS / (2.0 * np.pi))  # = fhog._BIN_SCALE
    zero32 = np.float32(0.0)
    for row in range(nh):
        for x in range(w):  # orientation bins (fhog._orientation_bins) and the two magnitude shares
            o = ang[row, x] * scale
            m = mag[row, x]
            if soft:
                lower = np.floor(o)
                od = o - lower
            else:
                lower = np.rint(o)
                od = zero32
            raw = min(int(lower), N_BINS)  # 0..18; 18 (o = 2 pi) is bin 0
            ob0[x] = raw if raw < N_BINS else 0
            ob1[x] = raw + 1 if raw < N_BINS - 1 else raw + 1 - N_BINS
            share = m * od
            m1[x] = share
            m0[x] = m - share
        acc[:] = 0.0
        # the reference's passes in its order (lower bin x left / right cell, then the upper bin; hard
        # bins: the upper bin's weights are +0.0 and change no sum); a weight is the float32 product,
        # summed in float64. Branch-free: one load-add-store per pixel (the earlier version summed a run
        # of pixels feeding the same entry in a register, the same additions, but its run test was
        # mispredicted on textured patches: 1.47 -> 1.01 ms for 5 windows of 248 x 100 px).
        for q in range(4 if soft else 2):
            xs, wx = (x0, wx0) if q % 2 == 0 else (x1, wx1)
            ob, mm = (ob0, m0) if q < 2 else (ob1, m1)
            for x in range(w):
                acc[xs[x] * N_BINS + ob[x]] += np.float64(mm[x] * wx[x])
        for j in range(k):
            hx[row, j] = np.float32(acc[j])
    for i in range(n):  # bilinear pooling of pixel rows into cell rows (fhog._pool_rows' order)
        for ci in range(hc):
            dst = out[i, ci]
            dst[:] = zero32
            for r in range(cell):
                src = hx[i * h + r + cell * ci]
                c = pool_w[r]
                for j in range(k):
                    dst[j] += c * src[j]
                nb = ci + pool_dir[r]
                if pool_dir[r] != 0 and 0 <= nb < hc:
                    src = hx[i * h + r + cell * nb]
                    c = pool_nb[r]
                    for j in range(k):
                        dst[j] += c * src[j]


@njit(cache=True, nogil=True)
def normalise_kernel(
    hist: np.ndarray,
    eps: np.float32,
    clip: np.float32,
    texture_weight: np.float32,
    window: np.ndarray,
    use_window: bool,
    energy: np.ndarray,
    inv: np.ndarray,
    both: np.ndarray,
    tsum: np.ndarray,
    out: np.ndarray,
) -> None:
    """FHOG block normalisation (fhog._fhog_numpy's passes, in their order per element).

    hist: (N, hc, wc, 18) float32 cell histograms; energy (hc+2, wc+2), inv (hc+1, wc+1), both (27, wc),
    tsum (4, wc) float32 scratch; out: (N, 31, hc, wc) float32; with use_window every value is then
    multiplied by window[y, x] (the cosine window of features.extract_features, the same float32
    product). Each cell row is copied channel first so that the inner loops run along x (vectorised).
    """
    n, hc, wc, _ = hist.shape
    one, half, zero32 = np.float32(1.0), np.float32(0.5), np.float32(0.0)
    for i in range(n):
        for y in range(hc):  # gradient energy of the 9 contrast-insensitive channels
            for x in range(wc):
                hh = hist[i, y, x]
                s = zero32
                for q in range(N_ORIENT):
                    v = hh[q] + hh[q + N_ORIENT]
                    s += v * v
                energy[y + 1, x + 1] = s
        for x in range(1, wc + 1):  # one replicated cell around the grid
            energy[0, x] = energy[1, x]
            energy[hc + 1, x] = energy[hc, x]
        for y in range(hc + 2):
            energy[y, 0] = energy[y, 1]
            energy[y, wc + 1] = energy[y, wc]
        for y in range(hc + 1):  # 2x2 blocks
            for x in range(wc + 1):
                b = energy[y, x] + energy[y + 1, x] + energy[y, x + 1] + energy[y + 1, x + 1]
                inv[y, x] = one / np.sqrt(b + eps)
        for y in range(hc):
            for x in range(wc):  # the row channel first: 18 sensitive, then 9 insensitive sums
                hh = hist[i, y, x]
                for c in range(N_BINS):
                    both[c, x] = hh[c]
                for c in range(N_ORIENT):
                    both[N_BINS + c, x] = hh[c] + hh[c + N_ORIENT]
            tsum[:] = zero32
            for c in range(3 * N_ORIENT):  # the 4 blocks around each cell, truncated, averaged
                src = both[c]
                dst = out[i, c, y]
                if c < N_BINS:  # sensitive channels also feed the 4 texture sums
                    for x in range(wc):
                        v = src[x]
                        t0 = min(v * inv[y, x], clip)
                        t1 = min(v * inv[y, x + 1], clip)
                        t2 = min(v * inv[y + 1, x], clip)
                        t3 = min(v * inv[y + 1, x + 1], clip)
                        val = (((t0 + t1) + t2) + t3) * half
                        dst[x] = val * window[y, x] if use_window else val
                        tsum[0, x] += t0
                        tsum[1, x] += t1
                        tsum[2, x] += t2
                        tsum[3, x] += t3
                else:
                    for x in range(wc):
                        v = src[x]
                        t0 = min(v * inv[y, x], clip)
                        t1 = min(v * inv[y, x + 1], clip)
                        t2 = min(v * inv[y + 1, x], clip)
                        t3 = min(v * inv[y + 1, x + 1], clip)
                        val = (((t0 + t1) + t2) + t3) * half
                        dst[x] = val * window[y, x] if use_window else val
            for q in range(4):
                dst = out[i, 3 * N_ORIENT + q, y]
                for x in range(wc):
                    val = tsum[q, x] * texture_weight
                    dst[x] = val * window[y, x] if use_window else val


@njit(cache=True, nogil=True)
def gradients_kernel(patches: np.ndarray, gx: np.ndarray, gy: np.ndarray) -> None:
    """[-1, 0, 1] / 2 gradients of N patches (N, H, W) float32 into gx, gy (N*H, W); one-sided differences
    (no halving) on the border rows and columns: the float32 operations of the reference's slices
    (test/fhog_reference.py `gradients`, and of `cv2.Sobel` ksize 1 scale 0.5 in fhog.gradients)."""
    n, h, w = patches.shape
    half = np.float32(0.5)
    for i in range(n):
        for y in range(h):
            row = patches[i, y]
            ox = gx[i * h + y]
            ox[0] = row[1] - row[0]
            for x in range(1, w - 1):
                ox[x] = (row[x + 1] - row[x - 1]) * half
            ox[w - 1] = row[w - 1] - row[w - 2]
            oy = gy[i * h + y]
            if y == 0:
                up, down, scale = patches[i, 0], patches[i, 1], False
            elif y == h - 1:
                up, down, scale = patches[i, h - 2], patches[i, h - 1], False
            else:
                up, down, scale = patches[i, y - 1], patches[i, y + 1], True
            for x in range(w):
                d = down[x] - up[x]
                oy[x] = d * half if scale else d
