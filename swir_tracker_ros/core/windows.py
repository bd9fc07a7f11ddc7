# SPDX-License-Identifier: Apache-2.0
"""Search-window geometry: window around a prediction, the 5 scale samples, the 3x3 re-detection grid."""

from __future__ import annotations

from collections.abc import Sequence

from swir_tracker_ros.types import Box

SCALE_FACTORS: tuple[float, ...] = (0.90, 0.95, 1.0, 1.05, 1.10)  # paper 000 Sec. III-B.2, set S plus 1


def search_window(cx: float, cy: float, w: float, h: float, padding: float) -> Box:
    """Window of (1 + padding) times the target size centred on (cx, cy)."""
    return Box.from_center(cx, cy, w * (1.0 + padding), h * (1.0 + padding))


def scale_windows(
    cx: float, cy: float, w: float, h: float, padding: float, factors: Sequence[float] = SCALE_FACTORS
) -> list[Box]:
    """Search windows for the target sizes factor * (w, h), all centred on the prediction."""
    return [search_window(cx, cy, w * f, h * f, padding) for f in factors]


def grid_windows(window: Box, overlap: float = 1.0 / 3.0) -> list[Box]:
    """3x3 grid of windows of the size of `window`, the centre one equal to it.

    Neighbours overlap by `overlap` of the window size along each axis (paper 000 Sec. III-B.4,
    dissertation §4.3), i.e. centre-to-centre steps of (1 - overlap) window widths / heights.
    Row-major order, the centre window at index 4.
    """
    sx = window.w * (1.0 - overlap)
    sy = window.h * (1.0 - overlap)
    return [window.shifted(dx * sx, dy * sy) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]


FFT_SIZES = ("auto", "smooth", "nearest", "exact")
"""Template cell counts: exact (rounded (1 + padding) x target), smooth (the next 5-smooth count), nearest
(the 5-smooth count nearest in ratio), auto (base.py: by variant)."""


def is_smooth(n: int) -> bool:
    """Whether n has no prime factor above 5."""
    for p in (2, 3, 5):
        while n % p == 0:
            n //= p
    return n == 1


def nearest_smooth_count(n: int) -> int:
    """The 5-smooth number nearest to n in ratio (the smaller one on a tie), at least 4."""
    n = max(4, int(n))
    up = smooth_count(n)
    down = n
    while not is_smooth(down):
        down -= 1
    return down if max(down, 4) * up >= n * n and down >= 4 else up


def smooth_count(n: int) -> int:
    """The smallest 5-smooth number (2^a 3^b 5^c) >= n.

    scipy.fft's pocketfft has dedicated radix-2/3/4/5 passes for real and complex transforms; any other
    prime factor goes through a generic O(p^2) pass (or Bluestein for a large prime), so a 62-cell axis
    (2 x 31) costs ~1.8x a 64-cell one (docs/speed.md, FFT-friendly template sizes).
    """
    n = max(1, int(n))
    while not is_smooth(n):
        n += 1
    return n


def template_size(
    w: float, h: float, padding: float, cell: int, scale: float, smooth: bool | str = False
) -> tuple[int, int]:
    """Model-space window in pixels: (1 + padding) x target x scale, rounded to whole cells (>= 4).

    `smooth`: each cell count raised to the next 5-smooth number (`smooth_count`) so the filters' FFTs
    run on fast sizes; the search window in the image stays (1 + padding) x target and is resampled to
    this template, i.e. stretched by at most a few per cent along an axis (every pixel <-> cell mapping
    uses window / template, so the geometry stays consistent).
    """
    cw = max(4, round(w * (1.0 + padding) * scale / cell))
    ch = max(4, round(h * (1.0 + padding) * scale / cell))
    if smooth == "nearest":
        cw, ch = nearest_smooth_count(cw), nearest_smooth_count(ch)
    elif smooth:
        cw, ch = smooth_count(cw), smooth_count(ch)
    return cw * cell, ch * cell
