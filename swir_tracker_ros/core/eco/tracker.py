# SPDX-License-Identifier: Apache-2.0
"""`ECOTracker`: the ECO base filter as a plain short-term tracker, `init(frame, box)` / `update(frame) ->
box`.

Every frame is detected at the last position and size and learned from (no gate, no failure report): the
tracker the ECO papers evaluate, used to measure the base filter on its own (docs/eco.md). Frames go through
the core's conditioner first (8-bit /255; 16-bit or float stretched by percentiles; core/conditioning.py).
"""

from __future__ import annotations

import numpy as np

from swir_tracker_ros.core.conditioning import ConditioningConfig, FrameConditioner
from swir_tracker_ros.core.eco.filter import ECODetection, ECOFilter
from swir_tracker_ros.core.eco.params import ECOParams
from swir_tracker_ros.types import Box


class ECOTracker:
    """Short-term ECO tracker; `last` is the last frame's detection (peak, PSR, APCE) for diagnostics."""

    def __init__(
        self, params: ECOParams | None = None, conditioning: ConditioningConfig | None = None
    ) -> None:
        self.filter = ECOFilter(params)
        self.conditioner = FrameConditioner(
            conditioning if conditioning is not None else ConditioningConfig()
        )
        self.last: ECODetection | None = None

    def init(self, frame: np.ndarray, box: Box) -> None:
        self.conditioner.reset()
        self.filter.init(self.conditioner(frame), box)
        self.last = None

    def update(self, frame: np.ndarray) -> Box:
        img = self.conditioner(frame)
        det = self.filter.detect(img)
        self.filter.update(img, det)
        self.last = det
        return self.filter.box
