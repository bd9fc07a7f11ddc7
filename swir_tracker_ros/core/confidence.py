# SPDX-License-Identifier: Apache-2.0
"""Confidence of a correlation response: peak value, PSR (paper 000 eq. 10), APCE (dissertation eq. 4.94)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Peak:
    """Sub-pixel location (row, col in response cells, wrapped to [-n/2, n/2)) and confidence."""

    row: float
    col: float
    value: float
    psr: float
    apce: float


def subpixel_offset(left: float, centre: float, right: float) -> float:
    """Vertex of the parabola through three samples at -1, 0, +1 (0 when flat), clamped to +-0.5."""
    denom = 2.0 * centre - left - right
    if denom <= 1e-12:
        return 0.0
    v = float(0.5 * (right - left) / denom)
    return -0.5 if v < -0.5 else 0.5 if v > 0.5 else v  # np.clip's result (NaN stays NaN), less overhead


PSR_FAILURE = 7.0
"""Paper 000 eq. 10's failure threshold: a response whose PSR is below it is a failure (occlusion)."""


def psr(response: np.ndarray, row: int, col: int, exclusion: int = 10) -> float:
    """Peak-to-sidelobe ratio (paper 000 eq. 10): (g_max - mu_sl) / sigma_sl.

    The sidelobe is the response outside an `exclusion` x `exclusion` region centred on the peak
    (circular, as the response of a correlation filter wraps around). The region is shrunk if it
    would leave fewer than 4 sidelobe samples.
    """
    h, w = response.shape
    eh = min(exclusion, max(h - 2, 1))
    ew = min(exclusion, max(w - 2, 1))
    rows = (row + np.arange(eh) - eh // 2) % h
    cols = (col + np.arange(ew) - ew // 2) % w
    region = response[np.ix_(rows, cols)]
    n = response.size - region.size
    if n < 2:
        return 0.0
    total = float(response.sum()) - float(region.sum())
    total_sq = float(np.square(response).sum()) - float(np.square(region).sum())
    mean = total / n
    var = max(total_sq / n - mean * mean, 0.0)
    std = np.sqrt(var)
    peak = float(response[row, col])
    return float((peak - mean) / std) if std > 1e-12 else 0.0


def apce(response: np.ndarray) -> float:
    """Average peak-to-correlation energy (dissertation eq. 4.94): |g_max - g_min|^2 / mean((g - g_min)^2)."""
    gmax = float(response.max())
    gmin = float(response.min())
    energy = float(np.mean(np.square(response - gmin)))
    return (gmax - gmin) ** 2 / energy if energy > 1e-20 else 0.0


def analyse(response: np.ndarray, exclusion: int = 10) -> Peak:
    """Sub-pixel peak location (circularly wrapped) with its value, PSR and APCE."""
    h, w = response.shape
    idx = int(np.argmax(response))
    r, c = divmod(idx, w)
    value = float(response[r, c])
    dr = (
        subpixel_offset(float(response[(r - 1) % h, c]), value, float(response[(r + 1) % h, c]))
        if h > 2
        else 0.0
    )
    dc = (
        subpixel_offset(float(response[r, (c - 1) % w]), value, float(response[r, (c + 1) % w]))
        if w > 2
        else 0.0
    )
    row, col = _signed(r + dr, h), _signed(c + dc, w)
    return Peak(row=row, col=col, value=value, psr=psr(response, r, c, exclusion), apce=apce(response))


def _signed(pos: float, n: int) -> float:
    """Circular response coordinate -> signed displacement: positions past the middle are negative."""
    return pos - n if pos >= n / 2 else pos


def analyse_batch(responses: np.ndarray, exclusion: int = 10) -> list[Peak]:
    """`analyse` of every response of a batch (N, rows, cols) at once: the same numbers, bit for bit.

    The per-window reductions (sums, squared sums, extrema, the sidelobe region's sums) are numpy reductions
    over each window's contiguous (rows, cols) block, which numpy carries out with the same pairwise
    summation as `analyse` does on one window; the scalar arithmetic is the same Python float arithmetic.
    One call costs ~15 numpy operations instead of ~40 per window (the re-detection lattice has up to 48);
    the peak and its four neighbours are read element by element (`ndarray.item`, the same floats).
    """
    resp = np.ascontiguousarray(responses)
    n_win, h, w = resp.shape
    if n_win == 0:
        return []
    flat = resp.reshape(n_win, h * w)
    idx = flat.argmax(axis=1)
    r_idx, c_idx = np.divmod(idx, w)
    eh = min(exclusion, max(h - 2, 1))
    ew = min(exclusion, max(w - 2, 1))
    rows = (r_idx[:, None] + (np.arange(eh) - eh // 2)) % h
    cols = (c_idx[:, None] + (np.arange(ew) - ew // 2)) % w
    region = resp[np.arange(n_win)[:, None, None], rows[:, :, None], cols[:, None, :]]
    total = resp.sum(axis=(1, 2)).tolist()
    total_sq = np.square(resp).sum(axis=(1, 2)).tolist()
    reg = region.sum(axis=(1, 2)).tolist()
    reg_sq = np.square(region).sum(axis=(1, 2)).tolist()
    gmin = flat.min(axis=1)
    # np.mean: the same sum, divided by the element count
    energy = (np.square(resp - gmin[:, None, None]).sum(axis=(1, 2)) / (h * w)).tolist()
    gmin_l = gmin.tolist()
    n_side = h * w - eh * ew
    out = []
    for k, i in enumerate(idx.tolist()):
        r, c = divmod(i, w)
        # the peak (also the maximum: argmax is the first maximum, or the first NaN as max's NaN) and the
        # three samples of each sub-pixel parabola, wrapped: per-element reads (5 windows: cheaper than
        # vectorised index arithmetic and a gather)
        at = flat[k].item
        value = at(i)
        dr = subpixel_offset(at(((r - 1) % h) * w + c), value, at(((r + 1) % h) * w + c)) if h > 2 else 0.0
        dc = subpixel_offset(at(r * w + (c - 1) % w), value, at(r * w + (c + 1) % w)) if w > 2 else 0.0
        row, col = _signed(r + dr, h), _signed(c + dc, w)
        if n_side < 2:
            p = 0.0
        else:
            mean = (total[k] - reg[k]) / n_side
            var = max((total_sq[k] - reg_sq[k]) / n_side - mean * mean, 0.0)
            std = math.sqrt(var)  # np.sqrt's correctly rounded square root
            p = (value - mean) / std if std > 1e-12 else 0.0
        e = energy[k]
        a = (value - gmin_l[k]) ** 2 / e if e > 1e-20 else 0.0
        out.append(Peak(row=row, col=col, value=value, psr=p, apce=a))
    return out
