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


def template_size(w: float, h: float, padding: float, cell: int, scale: float) -> tuple[int, int]:
    """Model-space window in pixels: (1 + padding) x target x scale, rounded to whole cells (>= 4)."""
    tw = max(4, round(w * (1.0 + padding) * scale / cell)) * cell
    th = max(4, round(h * (1.0 + padding) * scale / cell)) * cell
    return tw, th
