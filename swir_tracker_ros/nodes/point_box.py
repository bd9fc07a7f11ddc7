# SPDX-License-Identifier: Apache-2.0
"""A click on an image -> a box around the object under it (no messages, no ROS: numpy and OpenCV).

The operator points at a target (rqt_image_view's click, `track/select` with a point); the tracker needs a
box. `box_around_point` segments the object by its local contrast: the background level and noise are
the median and MAD of a ring around a window centred on the click, the object's polarity and contrast are
those of the strongest deviation next to the click, and the box is the bounding box of the connected
region (after a morphological closing, so that a textured target is one region) of pixels that deviate
from the background the same way by a good part of that contrast. When nothing stands out near the click,
or the region runs into the window's border twice (the click is on a large structure, not an object), the
box is a `default_size` square centred on the click.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from swir_tracker_ros.types import Box

SMOOTH_SIGMA = 1.0  # px: Gaussian blur against pixel noise and JPEG blocks before thresholding
MIN_CONTRAST = 6.0  # the click's contrast must exceed this many noise sigmas to be an object
NOISE_THRESHOLD = 3.0  # a pixel belongs to the object when it deviates by this many sigmas ...
CONTRAST_FRACTION = 0.2  # ... and by this fraction of the click's contrast
WINDOW_FACTOR = 2.0  # half-size of the first window, in default sizes (a second try doubles it)
CLOSE_FRACTION = 0.25  # closing kernel, in default sizes: joins the parts of a textured target


@dataclass(frozen=True)
class PointBox:
    """The box found for a click, whether it was segmented (False: the default square) and why."""

    box: Box
    segmented: bool
    note: str


def _grey(frame: np.ndarray) -> np.ndarray:
    img = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY) if frame.ndim == 3 else frame
    return img.astype(np.float32)


def _default(x: float, y: float, size: float, width: int, height: int, note: str) -> PointBox:
    return PointBox(_clip(Box.from_center(x, y, size, size), width, height), False, note)


def _clip(box: Box, width: int, height: int) -> Box:
    x0, y0 = max(box.x, 0.0), max(box.y, 0.0)
    x1, y1 = min(box.x + box.w, float(width)), min(box.y + box.h, float(height))
    return Box(x0, y0, max(x1 - x0, 1.0), max(y1 - y0, 1.0))


def _segment(img: np.ndarray, x: float, y: float, size: float, half: int) -> tuple[Box | None, str]:
    """The object's box in a (2 half + 1)^2 window at the click, or (None, why not)."""
    height, width = img.shape
    cx, cy = round(x), round(y)
    x0, y0 = max(cx - half, 0), max(cy - half, 0)
    x1, y1 = min(cx + half + 1, width), min(cy + half + 1, height)
    win = cv2.GaussianBlur(img[y0:y1, x0:x1], (0, 0), SMOOTH_SIGMA)
    band = max(2, half // 8)
    ring = np.concatenate([win[:band].ravel(), win[-band:].ravel(), win[:, :band].ravel(),
                           win[:, -band:].ravel()])
    level = float(np.median(ring))
    sigma = 1.4826 * float(np.median(np.abs(ring - level)))
    sigma = max(sigma, 1e-3 * (float(win.max()) - float(win.min())), 1e-6)
    dev = win - level
    r = max(2, round(size / 8))  # the click may miss a thin target by a few pixels
    px, py = cx - x0, cy - y0
    near = dev[max(py - r, 0):py + r + 1, max(px - r, 0):px + r + 1]
    iy, ix = np.unravel_index(int(np.argmax(np.abs(near))), near.shape)
    peak = float(near[iy, ix])
    if abs(peak) < MIN_CONTRAST * sigma:
        return None, f"contrast {abs(peak) / sigma:.1f} sigma at the click is below {MIN_CONTRAST:g}"
    sign = 1.0 if peak > 0 else -1.0
    mask = (sign * dev > max(NOISE_THRESHOLD * sigma, CONTRAST_FRACTION * abs(peak))).astype(np.uint8)
    k = max(3, round(CLOSE_FRACTION * size) | 1)
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    seed = (max(py - r, 0) + iy, max(px - r, 0) + ix)
    label = int(labels[seed])
    if label == 0:
        return None, "no region at the click"
    left, top, w, h = (int(v) for v in stats[label, :4])
    wh, ww = mask.shape
    at_border = ((left == 0 and x0 > 0) or (top == 0 and y0 > 0) or (left + w == ww and x1 < width)
                 or (top + h == wh and y1 < height))
    if at_border:
        return None, "the region reaches the window's border"
    return Box(float(x0 + left), float(y0 + top), float(w), float(h)), ""


def box_around_point(frame: np.ndarray, x: float, y: float, default_size: float = 32.0,
                     min_size: float = 8.0) -> PointBox:
    """The box of the object under the click (x = column, y = row, pixels) in `frame` (2-D or BGR).

    Tries a window of +-2 default sizes around the click, then one twice as large when the region reached
    the first window's border; falls back to a `default_size` square centred on the click. The result is
    at least `min_size` on a side and clipped to the image. Raises `ValueError` for a point outside the
    image or a non-positive size.
    """
    height, width = frame.shape[:2]
    if not (0.0 <= x < width and 0.0 <= y < height) or not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"point ({x:g}, {y:g}) is outside the {width}x{height} image")
    if not (default_size > 0 and min_size > 0):
        raise ValueError(f"default_size {default_size} and min_size {min_size} must be positive")
    img = _grey(frame)
    note = ""
    for factor in (WINDOW_FACTOR, 2 * WINDOW_FACTOR):
        box, note = _segment(img, x, y, default_size, max(4, round(factor * default_size)))
        if box is not None:
            w, h = max(box.w, min_size), max(box.h, min_size)
            grown = Box.from_center(box.cx, box.cy, w, h)
            return PointBox(_clip(grown, width, height), True, "segmented by contrast")
        if "border" not in note:
            break
    return _default(x, y, default_size, width, height, f"default box: {note}")
