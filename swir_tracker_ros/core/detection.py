# SPDX-License-Identifier: Apache-2.0
"""`Detection`: the peak of a base filter's response in one search window, in image coordinates."""

from __future__ import annotations

from dataclasses import dataclass

from swir_tracker_ros.types import Box


@dataclass(frozen=True)
class Detection:
    """Peak of the response in one search window, mapped to image coordinates."""

    cx: float
    cy: float
    peak: float
    psr: float
    apce: float
    scale: float  # size factor of the window relative to the predicted size
    window: Box
    # (filters that measure the size themselves) the measured aspect ratio w/h over the predicted one:
    # the size is (w sqrt(aspect), h / sqrt(aspect)) x scale
    aspect: float = 1.0
