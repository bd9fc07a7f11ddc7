# SPDX-License-Identifier: Apache-2.0
"""The `track/debug_image` picture (raw bgr8 or JPEG): the frame as 8-bit BGR with the box, search windows
and state drawn."""

from __future__ import annotations

import cv2
import numpy as np
from sensor_msgs.msg import CompressedImage, Image
from std_msgs.msg import Header

from msg_adapters.compressed import numpy_to_compressed
from msg_adapters.image import numpy_to_image
from swir_tracker_ros.types import Box, TrackResult, TrackState

# BGR colours per state.
COLOURS = {
    TrackState.TRACKING: (0, 220, 0),
    TrackState.OCCLUDED: (0, 200, 255),
    TrackState.LOST: (0, 0, 255),
    TrackState.IDLE: (200, 200, 200),
}
WINDOW_COLOUR = (255, 160, 0)


def to_bgr8(frame: np.ndarray) -> np.ndarray:
    """Display copy: 8-bit frames as they are, deeper ones stretched between 1st and 99th percentiles."""
    if frame.ndim == 3:
        return frame.copy() if frame.dtype == np.uint8 else cv2.convertScaleAbs(frame)
    if frame.dtype == np.uint8:
        grey = frame
    else:
        sample = frame[::4, ::4].astype(np.float32)
        finite = sample[np.isfinite(sample)]
        lo, hi = (np.percentile(finite, (1.0, 99.0)) if finite.size else (0.0, 1.0))
        scale = 255.0 / max(float(hi - lo), 1e-6)
        grey = cv2.convertScaleAbs(np.nan_to_num(frame.astype(np.float32)), alpha=scale, beta=-lo * scale)
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)


def _rect(img: np.ndarray, box: Box, colour: tuple[int, int, int], thickness: int) -> None:
    if not box.is_finite():
        return
    p0 = (round(box.x), round(box.y))
    p1 = (round(box.x + box.w), round(box.y + box.h))
    cv2.rectangle(img, p0, p1, colour, thickness)


def render_debug(frame: np.ndarray, result: TrackResult | None, header: Header) -> Image:
    """bgr8 Image of `frame` with search windows (orange), the box (colour by state) and a status line."""
    return numpy_to_image(debug_picture(frame, result), header, "bgr8")


def render_debug_compressed(frame: np.ndarray, result: TrackResult | None, header: Header,
                            quality: int = 80) -> CompressedImage:
    """The same picture as a JPEG CompressedImage (image_transport's `compressed` transport)."""
    return numpy_to_compressed(debug_picture(frame, result), header, "jpeg", quality)


def debug_picture(frame: np.ndarray, result: TrackResult | None) -> np.ndarray:
    """HxWx3 BGR uint8: the frame, the search windows (orange), the box (colour by state), a status line."""
    img = to_bgr8(frame)
    state = result.state if result is not None else TrackState.IDLE
    if result is not None and state is not TrackState.IDLE:
        for win in result.search_windows:
            _rect(img, win, WINDOW_COLOUR, 1)
        _rect(img, result.box, COLOURS[state], 2)
        text = (f"{state.value} peak {result.peak:.2f} psr {result.psr:.1f} apce {result.apce:.1f} "
                f"k {result.huber_threshold:.2f} {result.search_mode.value}")
    else:
        text = state.value
    cv2.putText(img, text, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, COLOURS[state], 1, cv2.LINE_AA)
    return img
