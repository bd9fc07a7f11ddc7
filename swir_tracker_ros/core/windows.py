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


FFT_SIZES = ("exact", "smooth5", "smooth7")
"""Template cell counts (`template_size`): exact ((1 + padding) x target rounded to whole cells), smooth5 /
smooth7 (each count moved to the nearest 5- / 7-smooth number)."""

_LARGEST_PRIME = {"smooth5": 5, "smooth7": 7}


def is_smooth(n: int, largest_prime: int = 5) -> bool:
    """Whether the positive integer n has no prime factor above `largest_prime` (5 or 7)."""
    for p in (2, 3, 5, 7):
        if p > largest_prime:
            break
        while n % p == 0:
            n //= p
    return n == 1


def nearest_smooth_count(n: int, largest_prime: int = 5) -> int:
    """The `largest_prime`-smooth number nearest to n (>= 4) in ratio, the smaller one on a tie.

    scipy.fft's pocketfft has dedicated radix-2/3/4/5 passes (and radix-7/11 passes for complex
    transforms); any other prime factor p goes through a generic O(p^2) pass, so e.g. a 62-cell axis
    (2 x 31) costs ~1.7x a 64-cell one per cell, a prime 59 ~2.5x a 60 (docs/experiments.md, FFT-friendly
    template sizes).
    """
    n = max(4, int(n))
    up = down = n
    while not is_smooth(up, largest_prime):
        up += 1
    while not is_smooth(down, largest_prime):
        down -= 1  # stops at 4 at the latest
    return down if down * up >= n * n else up


def template_size(
    w: float, h: float, padding: float, cell: int, scale: float, fft_sizes: str = "exact"
) -> tuple[int, int]:
    """Model-space window in pixels: (1 + padding) x target x scale, rounded to whole cells (>= 4).

    `fft_sizes` smooth5 / smooth7: each cell count then moved to the nearest 5- / 7-smooth number
    (`nearest_smooth_count`) so the filters' FFTs run on fast sizes. The search window in the image stays
    (1 + padding) x target and is resampled to this template, i.e. a few per cent finer or coarser along
    an axis; every pixel <-> cell mapping uses window / template, so the geometry stays consistent.
    """
    cw = max(4, round(w * (1.0 + padding) * scale / cell))
    ch = max(4, round(h * (1.0 + padding) * scale / cell))
    if fft_sizes != "exact":
        prime = _LARGEST_PRIME[fft_sizes]
        cw, ch = nearest_smooth_count(cw, prime), nearest_smooth_count(ch, prime)
    return cw * cell, ch * cell
