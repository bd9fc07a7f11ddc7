# SPDX-License-Identifier: Apache-2.0
"""Confidence of a correlation response: peak value, PSR (paper 000 eq. 10), APCE (dissertation eq. 4.94)."""

from __future__ import annotations

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
    return float(np.clip(0.5 * (right - left) / denom, -0.5, 0.5))


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
    row = r + dr
    col = c + dc
    if row >= h / 2:
        row -= h
    if col >= w / 2:
        col -= w
    return Peak(row=row, col=col, value=value, psr=psr(response, r, c, exclusion), apce=apce(response))
