# SPDX-License-Identifier: Apache-2.0
"""Compiled (numba) loops of the correlation filters' hot path outside the FFTs (issue 17).

Used by core/kcf.py (`gaussian_correlation`) and core/base.py (`_union_maps`) when numba is importable
and `kernels.USE_JIT` is on (core/kernels.py, the same switch as the compiled FHOG); otherwise they keep
their numpy code.
Each loop performs, element by element, the same float32 operations in the same order as the numpy code
it replaces, so responses and feature maps are bit-identical (test/test_core_speed_kernels.py):

- no `fastmath` (no re-association, no fused multiply-add);
- the channel sum of the cross-power spectrum accumulates channel after channel in complex64, with the
  products written out as numpy's complex multiply by the conjugate (re = ar br - ai bi, im = ar bi + ai br
  with b = conj(x), the same roundings as `np.einsum("nchw,chw->nhw", zf, np.conj(xf))`).

Compiled on first use and cached on disk (`cache=True`), like core/fhog_jit.py.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def cross_spectrum_kernel(zf: np.ndarray, xf: np.ndarray, out: np.ndarray) -> None:
    """out[n] = sum over c of zf[n, c] * conj(xf[c]) (complex64), channels summed in order.

    zf: (N, C, rows, k) complex64, xf: (C, rows, k) complex64, out: (N, rows, k) complex64 (paper 000
    eq. 7: the sum of the per-channel correlations in the Fourier domain). C-contiguous arrays (the
    callers') are summed over all rows * k frequencies at once, one long vectorised inner loop
    (`channel_sum_kernel`; k is only cols // 2 + 1, 13 at the default template: 2.7x faster for 5
    windows); other layouts row by row (`cross_spectrum_rows_kernel`). The same sums either way.
    """
    n_win, n_ch, rows, k = zf.shape
    if zf.flags.c_contiguous and xf.flags.c_contiguous and out.flags.c_contiguous:
        m = rows * k  # reshape: views of the contiguous arrays
        channel_sum_kernel(zf.reshape(n_win, n_ch, m), xf.reshape(n_ch, m), out.reshape(n_win, m))
    else:
        cross_spectrum_rows_kernel(zf, xf, out)


@njit(cache=True, nogil=True)
def channel_sum_kernel(zf: np.ndarray, xf: np.ndarray, out: np.ndarray) -> None:
    """out[n, j] = sum over c of zf[n, c, j] * conj(xf[c, j]): zf (N, C, M), xf (C, M), out (N, M)
    complex64. One row of accumulators per window stays in cache while the channels stream past."""
    n_win, n_ch, m = zf.shape
    acc_r = np.empty(m, dtype=np.float32)
    acc_i = np.empty(m, dtype=np.float32)
    for n in range(n_win):
        for j in range(m):
            acc_r[j] = np.float32(0.0)
            acc_i[j] = np.float32(0.0)
        for c in range(n_ch):
            zc = zf[n, c]
            xc = xf[c]
            for j in range(m):
                a = zc[j]
                b = xc[j]
                ar, ai, br, bi = a.real, a.imag, b.real, -b.imag
                acc_r[j] += ar * br - ai * bi
                acc_i[j] += ar * bi + ai * br
        dst = out[n]
        for j in range(m):
            dst[j] = complex(acc_r[j], acc_i[j])


@njit(cache=True, nogil=True)
def cross_spectrum_rows_kernel(zf: np.ndarray, xf: np.ndarray, out: np.ndarray) -> None:
    """`cross_spectrum_kernel` for any layout: one row of accumulators per (n, row) while the channels
    stream past."""
    n_win, n_ch, rows, k = zf.shape
    acc_r = np.empty(k, dtype=np.float32)
    acc_i = np.empty(k, dtype=np.float32)
    for n in range(n_win):
        for y in range(rows):
            for x in range(k):
                acc_r[x] = np.float32(0.0)
                acc_i[x] = np.float32(0.0)
            for c in range(n_ch):
                for x in range(k):
                    a = zf[n, c, y, x]
                    b = xf[c, y, x]
                    ar, ai, br, bi = a.real, a.imag, b.real, -b.imag
                    acc_r[x] += ar * br - ai * bi
                    acc_i[x] += ar * bi + ai * br
            for x in range(k):
                out[n, y, x] = complex(acc_r[x], acc_i[x])


@njit(cache=True, nogil=True)
def cut_windows_kernel(
    feats: np.ndarray, win: np.ndarray, r0: np.ndarray, c0: np.ndarray, out: np.ndarray
) -> None:
    """out[n] = feats[:, r0[n] : r0[n] + rows, c0[n] : c0[n] + cols] * win (float32 products).

    feats: (C, H, W) float32 union feature map, win: (rows, cols) float32 cosine window, out: (N, C, rows,
    cols) float32: the window maps cut from one union map (`BaseFilter._union_maps`).
    """
    n_win, n_ch, rows, cols = out.shape
    for n in range(n_win):
        for c in range(n_ch):
            for y in range(rows):
                src = feats[c, r0[n] + y]
                for x in range(cols):
                    out[n, c, y, x] = src[c0[n] + x] * win[y, x]


@njit(cache=True, nogil=True)
def stretch_kernel(src: np.ndarray, lo: np.float32, scale: np.float32, out: np.ndarray) -> None:
    """out = clip((float32(src) - lo) * scale, 0, 1): `FrameConditioner`'s percentile stretch of an 8/16-bit
    frame (conversion, subtraction, multiplication and clip, each a float32 operation as in numpy's
    passes: a NaN would stay NaN as in np.clip) in one pass instead of four."""
    rows, cols = src.shape
    zero, one = np.float32(0.0), np.float32(1.0)
    for y in range(rows):
        for x in range(cols):
            v = (np.float32(src[y, x]) - lo) * scale
            if v < zero:
                v = zero
            elif v > one:
                v = one
            out[y, x] = v


@njit(cache=True, nogil=True)
def cell_means_kernel(planes: np.ndarray, cell: int, out: np.ndarray) -> None:
    """Means of `cell` x `cell` blocks: planes (N, K, H, W) float32 -> out (N, K, H // cell, W // cell).

    numpy's `mean(axis=(3, 5), dtype=float32)` of the (N, K, hc, cell, wc, cell) view (channels.cell_means)
    sums, for each block, each pixel row's `cell` values from 0 (its contiguous inner reduction; plain
    left-to-right for fewer than 8 values) and adds the row sums in row order, then divides by the count:
    the same float32 operations here, for cell < 8 (8 and more: numpy's unrolled pairwise sum, not used).
    """
    n, k, _, _ = planes.shape
    hc, wc = out.shape[2], out.shape[3]
    count = np.float32(cell * cell)
    zero = np.float32(0.0)
    # a row of block sums at a time, the pixel rows in turn: each block's additions in the order above, the
    # loop over the blocks innermost (vectorised; the 4-pixel row sums written out for the default cell)
    acc = np.empty(wc, dtype=np.float32)
    for i in range(n):
        for c in range(k):
            src = planes[i, c]
            dst = out[i, c]
            for y in range(hc):
                for x in range(wc):
                    acc[x] = zero
                for r in range(cell):
                    row = src[y * cell + r]
                    if cell == 4:
                        for x in range(wc):
                            p = 4 * x
                            acc[x] += (((zero + row[p]) + row[p + 1]) + row[p + 2]) + row[p + 3]
                    else:
                        for x in range(wc):
                            t = zero
                            for q in range(cell):
                                t += row[x * cell + q]
                            acc[x] += t
                for x in range(wc):
                    dst[y, x] = acc[x] / count


@njit(cache=True, nogil=True)
def order_statistics_kernel(src: np.ndarray, step: int, ranks: np.ndarray, out: np.ndarray) -> None:
    """out[i] = the ranks[i]-th smallest (0-based) value of the subsample src[::step, ::step] (uint8/uint16).

    `conditioning.percentile_limits`' order statistics without copying the subsample twice (slicing,
    float32) and partitioning it: a count of the high bytes finds each rank's bucket, a second pass counts
    the low bytes inside those buckets. Integer counting: the values are exactly those of np.partition at
    the same ranks (each rank must lie in [0, n), n the subsample size).
    """
    rows, cols = src.shape
    n_r = (rows + step - 1) // step
    n_c = (cols + step - 1) // step
    n_k = ranks.shape[0]
    # four interleaved counts (hist[256 q + b]): neighbouring pixels of a smooth frame share a bucket, and
    # a single count would make each increment wait for the previous one
    hist = np.zeros(4 * 256, dtype=np.int32)
    for y in range(n_r):
        row = src[y * step]
        x = 0
        while x + 3 < n_c:
            hist[np.int32(row[x * step]) >> 8] += 1
            hist[256 + (np.int32(row[(x + 1) * step]) >> 8)] += 1
            hist[512 + (np.int32(row[(x + 2) * step]) >> 8)] += 1
            hist[768 + (np.int32(row[(x + 3) * step]) >> 8)] += 1
            x += 4
        while x < n_c:
            hist[np.int32(row[x * step]) >> 8] += 1
            x += 1
    slot = np.full(256, -1, dtype=np.int32)  # bucket -> row of hist_lo; -1: no rank falls in it
    rank_slot = np.empty(n_k, dtype=np.int32)
    rest = np.empty(n_k, dtype=np.int64)
    bucket = np.empty(n_k, dtype=np.int32)
    n_s = 0
    for k in range(n_k):
        left = ranks[k]
        b = 0
        while True:
            c = hist[b] + hist[256 + b] + hist[512 + b] + hist[768 + b]
            if left < c:
                break
            left -= c
            b += 1
        if slot[b] < 0:
            slot[b] = n_s
            n_s += 1
        rank_slot[k], rest[k], bucket[k] = slot[b], left, b
    hist_lo = np.zeros((n_s, 256), dtype=np.int32)
    for y in range(n_r):
        row = src[y * step]
        for x in range(n_c):
            v = np.int32(row[x * step])
            s = slot[v >> 8]
            if s >= 0:
                hist_lo[s, v & 255] += 1
    for k in range(n_k):
        counts = hist_lo[rank_slot[k]]
        left = rest[k]
        lo = 0
        while left >= counts[lo]:
            left -= counts[lo]
            lo += 1
        out[k] = (bucket[k] << 8) | lo
